"""Choosing a backend: the :class:`Reasoner` protocol and :func:`make_reasoner`."""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

from causalsplat.reason.answer import Answer
from causalsplat.reason.context import SceneContext
from causalsplat.reason.errors import UnknownReasonerError

REASONERS: tuple[str, ...] = ("offline", "vlm")


@runtime_checkable
class Reasoner(Protocol):
    """Anything that answers an instruction on a scene."""

    name: str

    def answer(self, text: str, ctx: SceneContext) -> Answer: ...


def make_reasoner(reasoner: str | Reasoner = "offline", **options: Any) -> Reasoner:
    """A reasoner by name (``"offline"`` or ``"vlm"``, with its options), or ``reasoner``
    itself when it already is one.

    ``offline`` options: ``embeddings`` (``False``, ``True`` or ``"auto"``).
    ``vlm`` options: those of :class:`~causalsplat.reason.vlm.VLMReasoner` (``config``,
    ``client``, ``fallback``, ``record``, ``replay``...).
    """
    if not isinstance(reasoner, str):
        if options:
            raise UnknownReasonerError("options are only accepted with a reasoner name")
        return reasoner
    if reasoner == "offline":
        from causalsplat.reason.offline import OfflineReasoner

        return OfflineReasoner(**options)
    if reasoner == "vlm":
        from causalsplat.reason.vlm import VLMReasoner

        return VLMReasoner(**options)
    raise UnknownReasonerError(
        f"unknown reasoner {reasoner!r}; expected one of: {', '.join(REASONERS)}"
    )
