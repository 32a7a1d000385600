"""Errors of the build pipeline."""

from __future__ import annotations

from causalsplat.errors import CausalSplatError


class BuildError(CausalSplatError):
    """The inputs are well formed but give nothing to build from (no view sees a masked
    Gaussian, say); the message says what was found and which option to check."""


class CoverageError(BuildError):
    """The PLY and the cameras (or masks) do not belong together: the views see too few
    Gaussians, or the masks fall where no Gaussian projects
    (:mod:`causalsplat.build.coverage`); the message gives both shares and thresholds."""


class StageError(BuildError):
    """A build stage failed for a reason no check foresaw (an exception that is not a
    :class:`~causalsplat.errors.CausalSplatError`: a numerical failure on an unusual scene, a
    bug). The message is one line: the scene folder, the stage, the original error's type
    and the first line of its message; the original is chained as ``__cause__``.

    Attributes:
        stage: the stage's name (``load``, ``rasterize``, ``field``, ``instances``, ``graph``).
    """

    def __init__(self, where: str, stage: str, cause: BaseException) -> None:
        super().__init__(f"{where}: {stage} stage failed: {describe_error(cause)}")
        self.stage = stage


#: Longest reason a :class:`StageError` quotes from the error it wraps (characters).
MAX_REASON = 300


def describe_error(exc: BaseException) -> str:
    """``Type: first line of the message`` of ``exc`` (at most :data:`MAX_REASON` long);
    an ``OSError`` with a file name reads ``Type: strerror: filename``."""
    if isinstance(exc, OSError) and exc.filename is not None:
        text = f"{exc.strerror}: {exc.filename}"
    else:
        text = next((line.strip() for line in str(exc).splitlines() if line.strip()), "")
    reason = f"{type(exc).__name__}: {text}" if text else type(exc).__name__
    return reason if len(reason) <= MAX_REASON else reason[: MAX_REASON - 3] + "..."
