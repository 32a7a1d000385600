"""The error tree of :mod:`causalsplat` (the top floor: perception, reasoning, API, CLI)."""

from __future__ import annotations


class CausalSplatError(Exception):
    """Root of every error raised by :mod:`causalsplat` itself."""


class InputFormatError(CausalSplatError, ValueError):
    """An input file (objects JSON, PLY, cameras, masks, queries...) is malformed.

    The message names the file and the offending field or value.
    """


class MissingDependencyError(CausalSplatError, ImportError):
    """An optional dependency is not installed; the message gives the install command."""
