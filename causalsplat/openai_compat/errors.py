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
    """A reply is unusable: cut off (:class:`VLMTruncatedError`), empty, not JSON, or
    not valid for what was asked. ``reason`` is a short tag (``truncated``, ``json``,
    ``schema``, ``unknown_id``, ``unknown_name``...)."""

    def __init__(self, message: str, *, reason: str) -> None:
        super().__init__(message)
        self.reason = reason

    def after(self, first: VLMReplyError) -> VLMReplyError:
        """This error (same type and attributes), its message also saying why the first
        reply, the one this was the retry of, was rejected."""
        out = type(self).__new__(type(self))
        out.__dict__.update(self.__dict__)
        out.args = (f"{self} (on the retry; the first reply: {first})",)
        return out


class VLMRefusalError(VLMReplyError):
    """The model refused to answer (OpenAI's ``message.refusal``): asking again the same
    way would not help, so it is not retried."""

    def __init__(self, refusal: str) -> None:
        super().__init__(f"the model refused: {refusal}", reason="refusal")
        self.refusal = refusal


class VLMTruncatedError(VLMReplyError):
    """The reply was cut off by its token budget (``finish_reason == "length"``).

    ``max_tokens`` is the budget it was generated under (``None`` when unknown).
    """

    def __init__(self, max_tokens: int | None = None) -> None:
        budget = f" at max_tokens={max_tokens}" if max_tokens is not None else ""
        super().__init__(
            f"the reply was cut off{budget} (finish_reason=length)", reason="truncated"
        )
        self.max_tokens = max_tokens


class ReplayMissError(VLMError):
    """Replay mode, and the recording holds no exchange for this request."""
