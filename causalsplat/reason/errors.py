"""The error tree of :mod:`causalsplat.reason`.

``ReasonError`` (a :class:`~causalsplat.errors.CausalSplatError`) is the root. The offline
reasoner raises :class:`InstructionError` when it cannot make a program of an instruction
(nothing in it names anything in the scene, say); the VLM backend's transport and reply
problems are :class:`causalsplat.openai_compat.VLMError` and never escape ``ask`` unless
the fallback is switched off.
"""

from __future__ import annotations

from causalsplat.errors import CausalSplatError


class ReasonError(CausalSplatError):
    """Root of every error raised by the reasoner."""


class InstructionError(ReasonError, ValueError):
    """An instruction cannot be turned into a program (the message says why)."""


class UnknownReasonerError(ReasonError, ValueError):
    """A reasoner name is not one of the known backends."""


class QueriesFileError(ReasonError, ValueError):
    """A queries file (docs/formats.md) is malformed; the message names the file and the field."""


class UnlabelledSceneError(ReasonError):
    """The scene's entities have no categories (built from masks without labels and no
    labeller): no instruction can name anything in it. The message says how to add them."""
