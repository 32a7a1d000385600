"""The error tree of :mod:`causalsplat.openai_compat` (a vision-language model server)."""

from __future__ import annotations

from causalsplat.errors import CausalSplatError


class VLMError(CausalSplatError):
    """Root of every problem with a VLM server or its replies."""


class VLMConfigError(VLMError, ValueError):
    """No base URL or model configured (the message names the setting)."""


class VLMTransportError(VLMError):
    """The server could not be reached or answered with an HTTP error.

    ``status`` is the HTTP status (``None`` for connection problems and timeouts).
    """

    def __init__(self, message: str, *, status: int | None = None) -> None:
        super().__init__(message)
        self.status = status


class VLMTimeoutError(VLMTransportError):
    """The server did not answer within the configured timeout."""


class VLMReplyError(VLMError):
    """A reply is unusable: cut off (``finish_reason == "length"``), empty, not JSON, or
    not valid for what was asked. ``reason`` is a short tag (``truncated``, ``json``,
    ``schema``, ``unknown_id``, ``unknown_name``...)."""

    def __init__(self, message: str, *, reason: str) -> None:
        super().__init__(message)
        self.reason = reason


class ReplayMissError(VLMError):
    """Replay mode, and the recording holds no exchange for this request."""
