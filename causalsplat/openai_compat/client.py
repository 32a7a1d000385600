"""A small client for OpenAI-compatible chat-completions servers, with record and replay.

Any server that speaks the chat-completions API works (vLLM, SGLang, Ollama, llama.cpp,
LM Studio, hosted APIs): :class:`VLMConfig` names its base URL, the model and the key,
from arguments or the environment (``CAUSALSPLAT_VLM_BASE_URL``, ``CAUSALSPLAT_VLM_MODEL``,
``CAUSALSPLAT_VLM_API_KEY``, and a reply's token budget ``CAUSALSPLAT_VLM_MAX_TOKENS``).
Requests go through the ``openai`` package (the ``vlm`` extra) with a timeout; every
failure becomes a typed :class:`~causalsplat.openai_compat.errors.VLMError`:

- a busy server (HTTP 429 or 503) is asked again after the wait its ``Retry-After`` header
  gives, else 0.5 s doubling, at most :data:`RETRIES` times and never longer than
  :data:`MAX_WAIT_S` per wait; other HTTP errors are not retried;
- a 400 that refuses ``max_tokens`` in favour of ``max_completion_tokens`` (OpenAI's newer
  reasoning models), or refuses a temperature, is sent again that way once, and the client
  keeps sending it so;
- a refusal (``message.refusal``) is :class:`~causalsplat.openai_compat.errors.VLMRefusalError`;
  a body that is an HTML page or not JSON says so.

Record and replay: with ``record=PATH`` every exchange is appended to a JSONL file, one
object per line, ``{"key", "request", "reply"}`` or ``{"key", "request", "error"}``, where
``key`` is the SHA-256 of the canonical JSON of the request without the model name
(messages, response format, sampling settings; never the API key), so a recording replays
whatever model name is configured. With ``replay=PATH`` requests are answered from
such a file, in recorded order for repeated requests, without the network (and without
the ``openai`` package): a VLM evaluation re-runs deterministically offline.

A reply cut off by its token budget (``finish_reason == "length"``) is told apart from other
unusable replies (:func:`check_finished` raises
:class:`~causalsplat.openai_compat.errors.VLMTruncatedError`); callers retry it with a larger
budget (:func:`retry_budget`, a per-call ``max_tokens`` of :meth:`ChatClient.complete`).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import time
from collections import defaultdict, deque
from dataclasses import dataclass, replace
from datetime import datetime
from email.utils import parsedate_to_datetime
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

from causalsplat._json import utf8_text
from causalsplat.openai_compat.errors import (
    ReplayMissError,
    VLMConfigError,
    VLMError,
    VLMRefusalError,
    VLMReplyError,
    VLMTimeoutError,
    VLMTransportError,
    VLMTruncatedError,
)

ENV_BASE_URL = "CAUSALSPLAT_VLM_BASE_URL"
ENV_MODEL = "CAUSALSPLAT_VLM_MODEL"
ENV_API_KEY = "CAUSALSPLAT_VLM_API_KEY"
ENV_MAX_TOKENS = "CAUSALSPLAT_VLM_MAX_TOKENS"
#: The default token budget of one reply.
DEFAULT_MAX_TOKENS = 1024
#: A retry after a cut-off reply doubles the budget, up to this many tokens (a budget set
#: higher than this is kept as it is).
RETRY_MAX_TOKENS = 8192
INSTALL_HINT = "pip install 'causalsplat[vlm]' (the openai package)"
Message = dict[str, Any]


@dataclass(frozen=True, slots=True)
class VLMConfig:
    """Where the server is and how to ask it.

    Attributes:
        base_url: the server's OpenAI-compatible API root (``http://host:8000/v1``).
        model: the model name the server knows.
        api_key: the key (servers that need none accept any string).
        timeout_s: seconds to wait for one reply.
        max_tokens: most tokens of a reply (a positive int; the retry after a cut-off
            reply asks for :func:`retry_budget` of it).
        temperature: sampling temperature (0: as deterministic as the server allows).
        seed: sampling seed sent to servers that honour one.
    """

    base_url: str | None = None
    model: str | None = None
    api_key: str | None = None
    timeout_s: float = 60.0
    max_tokens: int = DEFAULT_MAX_TOKENS
    temperature: float = 0.0
    seed: int | None = 0

    def __post_init__(self) -> None:
        check_max_tokens(self.max_tokens, "max_tokens")
        if self.base_url is not None:
            check_base_url(self.base_url)

    @classmethod
    def from_env(cls, **overrides: Any) -> VLMConfig:
        """Settings from the environment, then ``overrides`` (``None`` values ignored).

        Raises :class:`VLMConfigError` when ``CAUSALSPLAT_VLM_MAX_TOKENS`` is set but not a
        positive integer.
        """
        overrides = {k: v for k, v in overrides.items() if v is not None}
        raw_budget = os.environ.get(ENV_MAX_TOKENS, "").strip()
        if raw_budget and "max_tokens" not in overrides:
            overrides["max_tokens"] = parse_max_tokens(raw_budget, ENV_MAX_TOKENS)
        base = cls(
            base_url=os.environ.get(ENV_BASE_URL) or None,
            model=os.environ.get(ENV_MODEL) or None,
            api_key=os.environ.get(ENV_API_KEY) or None,
        )
        return replace(base, **overrides)


def check_base_url(url: str) -> str:
    """``url`` if it is an absolute http(s) URL with a host, else :class:`VLMConfigError`.

    >>> check_base_url("http://127.0.0.1:8080/v1")
    'http://127.0.0.1:8080/v1'
    >>> try:
    ...     check_base_url("::::")
    ... except VLMConfigError as exc:
    ...     print(exc)
    the VLM base URL must be http(s)://HOST[:PORT]/PATH, got '::::'
    """
    try:
        parts = urlsplit(url)
        parts.port  # noqa: B018 - raises ValueError on a port out of range
    except ValueError:
        parts = None
    if parts is None or parts.scheme not in ("http", "https") or not parts.hostname:
        raise VLMConfigError(f"the VLM base URL must be http(s)://HOST[:PORT]/PATH, got {url!r}")
    return url


def check_max_tokens(value: object, source: str) -> int:
    """``value`` if it is a positive int, else :class:`VLMConfigError` naming ``source``."""
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise VLMConfigError(f"{source} must be a positive integer, got {value!r}")
    return value


def parse_max_tokens(text: str, source: str) -> int:
    """A token budget from text (a CLI option or an environment variable); a
    :class:`VLMConfigError` naming ``source`` unless it is a positive integer."""
    stripped = text.strip()
    if not stripped.isascii() or not stripped.isdigit() or int(stripped) < 1:
        raise VLMConfigError(f"{source} must be a positive integer, got {text!r}")
    return int(stripped)


def with_note(messages: list[Message], note: str) -> list[Message]:
    """``messages`` with ``note`` added to the last one, a user message (for a retry that
    asks again instead of answering a cut-off reply: roles keep alternating, as some chat
    templates require, and the cut-off text is not sent back)."""
    last = dict(messages[-1])
    content = last["content"]
    if isinstance(content, str):
        last["content"] = f"{content}\n\n{note}"
    else:
        last["content"] = [*content, {"type": "text", "text": note}]
    return [*messages[:-1], last]


def retry_budget(max_tokens: int) -> int:
    """The budget of a retry after a reply cut off at ``max_tokens``: twice as many, capped
    at :data:`RETRY_MAX_TOKENS` (never less than ``max_tokens``)."""
    return max(max_tokens, min(2 * max_tokens, RETRY_MAX_TOKENS))


@dataclass(frozen=True, slots=True)
class ChatReply:
    """One reply: its text, why generation stopped, and which model answered."""

    content: str
    finish_reason: str | None
    model: str | None = None

    @property
    def cut_off(self) -> bool:
        """Whether generation stopped at the token budget (``finish_reason == "length"``)."""
        return self.finish_reason == "length"


def check_finished(reply: ChatReply, max_tokens: int | None = None) -> None:
    """Raise :class:`VLMTruncatedError` when ``reply`` was cut off at ``max_tokens``."""
    if reply.cut_off:
        raise VLMTruncatedError(max_tokens)


def request_key(request: dict[str, Any]) -> str:
    """SHA-256 of the canonical JSON of a request less its model (the record/replay key)."""
    keyed = {k: v for k, v in request.items() if k != "model"}
    text = json.dumps(keyed, sort_keys=True, separators=(",", ":"), ensure_ascii=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


class ChatClient:
    """Chat completions against one server (module docstring).

    Args:
        config: the server settings (default: from the environment).
        record: append every exchange to this JSONL file.
        replay: answer from this JSONL file instead of the network.
    """

    def __init__(
        self,
        config: VLMConfig | None = None,
        *,
        record: str | Path | None = None,
        replay: str | Path | None = None,
    ) -> None:
        self.config = config or VLMConfig.from_env()
        self.record_path = Path(record) if record is not None else None
        self._replay: dict[str, deque[dict[str, Any]]] | None = None
        self._openai: Any = None
        self._renamed_budget = False  # the server takes max_completion_tokens
        self._no_temperature = False  # the model takes only its default temperature
        if replay is not None:
            self._replay = _read_recording(Path(replay))
            return
        if not self.config.base_url:
            raise VLMConfigError(f"no VLM server: set {ENV_BASE_URL} or pass a base URL")
        if not self.config.model:
            raise VLMConfigError(f"no VLM model: set {ENV_MODEL} or pass a model name")
        try:
            import openai
        except ImportError as exc:
            raise VLMConfigError(f"the VLM backend needs the vlm extra: {INSTALL_HINT}") from exc
        self._openai = openai.OpenAI(
            base_url=self.config.base_url,
            api_key=self.config.api_key or "not-needed",
            timeout=self.config.timeout_s,
            max_retries=0,
        )

    def __repr__(self) -> str:
        mode = "replay" if self._replay is not None else self.config.base_url
        return f"ChatClient({mode!r}, model={self.config.model!r})"

    def request(
        self,
        messages: list[Message],
        response_format: dict[str, Any] | None,
        max_tokens: int | None = None,
    ) -> dict[str, Any]:
        """The request document (also the record/replay key's input); ``max_tokens``
        overrides the configured budget."""
        budget = self.config.max_tokens if max_tokens is None else max_tokens
        out: dict[str, Any] = {
            "model": self.config.model,
            "messages": messages,
            "temperature": self.config.temperature,
            "max_tokens": check_max_tokens(budget, "max_tokens"),
        }
        if self.config.seed is not None:
            out["seed"] = self.config.seed
        if response_format is not None:
            out["response_format"] = response_format
        return out

    def complete(
        self,
        messages: list[Message],
        *,
        response_format: dict[str, Any] | None = None,
        max_tokens: int | None = None,
    ) -> ChatReply:
        """One chat completion, with at most ``max_tokens`` tokens (default: the config's).

        Raises :class:`VLMTransportError` (HTTP error, no connection),
        :class:`VLMTimeoutError`, :class:`VLMReplyError` (no choices) or, in replay mode,
        :class:`ReplayMissError`. A cut-off reply is returned (see :func:`check_finished`).
        """
        request = self.request(messages, response_format, max_tokens)
        key = request_key(request)
        if self._replay is not None:
            return _replayed(self._replay, key)
        try:
            reply = self._call(request)
        except VLMError as exc:
            self._record(key, request, error=exc)
            raise
        self._record(key, request, reply=reply)
        return reply

    def _call(self, request: dict[str, Any]) -> ChatReply:
        """One exchange (module docstring): busy answers (429, 503) are retried after the
        wait the server asks for (``Retry-After``) or a doubling one, at most
        :data:`RETRIES` times; a request parameter the model refuses is adapted once."""
        openai = __import__("openai")
        where = f"the VLM server at {self.config.base_url}"
        attempt = 0
        while True:
            try:
                response = self._openai.chat.completions.create(**self._adapted(request))
            except openai.APITimeoutError as exc:
                raise VLMTimeoutError(
                    f"{where} did not answer within {self.config.timeout_s:g} s"
                ) from exc
            except openai.APIStatusError as exc:
                code = exc.status_code
                if code in BUSY_STATUSES and attempt < RETRIES:
                    wait = retry_wait(exc.response.headers.get("retry-after"), attempt)
                    if wait is not None:
                        time.sleep(wait)
                        attempt += 1
                        continue
                if code == 400 and self._adapt(exc):
                    continue
                busy = f" (still busy after {attempt} retries)" if code in BUSY_STATUSES else ""
                raise VLMTransportError(
                    f"{where} answered HTTP {code}{busy}: {_body_text(exc)[:200]}", status=code
                ) from exc
            except openai.APIResponseValidationError as exc:
                raise VLMReplyError(
                    f"{where} answered with a body that is not a chat completion: {exc}"[:300],
                    reason="not_completion",
                ) from exc
            except openai.APIError as exc:  # connection errors
                raise VLMTransportError(f"{where} failed: {exc}") from exc
            return _reply(response, where)

    def _adapted(self, request: dict[str, Any]) -> dict[str, Any]:
        """The request as this server takes it (see :meth:`_adapt`)."""
        if not self._renamed_budget and not self._no_temperature:
            return request
        out = dict(request)
        if self._renamed_budget and "max_tokens" in out:
            out["max_completion_tokens"] = out.pop("max_tokens")
        if self._no_temperature:
            out.pop("temperature", None)
        return out

    def _adapt(self, exc: Any) -> bool:
        """Whether a 400 refused a parameter that can be sent otherwise, and it now is:
        newer OpenAI models take ``max_completion_tokens`` instead of ``max_tokens``, and
        some only their default temperature."""
        text = _body_text(exc)
        if "max_completion_tokens" in text and "max_tokens" in text and not self._renamed_budget:
            self._renamed_budget = True
            return True
        if "temperature" in text and not self._no_temperature:
            self._no_temperature = True
            return True
        return False

    def _record(
        self,
        key: str,
        request: dict[str, Any],
        *,
        reply: ChatReply | None = None,
        error: VLMError | None = None,
    ) -> None:
        if self.record_path is None:
            return
        entry: dict[str, Any] = {"key": key, "request": request}
        if reply is not None:
            entry["reply"] = {
                "content": reply.content,
                "finish_reason": reply.finish_reason,
                "model": reply.model,
            }
        else:
            assert error is not None
            entry["error"] = {
                "type": type(error).__name__,
                "message": str(error),
                "status": getattr(error, "status", None),
            }
        line = json.dumps(entry, sort_keys=True, ensure_ascii=False)
        with self.record_path.open("a", encoding="utf-8") as handle:
            handle.write(line + "\n")


#: HTTP statuses of a server that is busy, not broken: retried.
BUSY_STATUSES = frozenset({429, 503})
#: Retries of a busy server, and the longest wait honoured (a server asking for longer is
#: reported, not waited for).
RETRIES = 3
MAX_WAIT_S = 30.0


def retry_wait(retry_after: str | None, attempt: int) -> float | None:
    """Seconds to wait before retry ``attempt`` (0-based): what ``Retry-After`` asks for
    (seconds or an HTTP date), else 0.5 s doubling; ``None`` when the server asks for more
    than :data:`MAX_WAIT_S`.

    >>> retry_wait("2", 0), retry_wait(None, 0), retry_wait(None, 2), retry_wait("3600", 0)
    (2.0, 0.5, 2.0, None)
    """
    wait: float | None = None
    if retry_after:
        try:
            wait = float(retry_after)
        except ValueError:
            try:
                when = parsedate_to_datetime(retry_after)
                wait = (when - datetime.now(when.tzinfo)).total_seconds()
            except (TypeError, ValueError):
                wait = None
    if wait is None or not math.isfinite(wait):
        wait = 0.5 * 2**attempt
    wait = max(0.0, wait)
    return None if wait > MAX_WAIT_S else wait


def _body_text(exc: Any) -> str:
    """An HTTP error's body as text (OpenAI's error message when it is one)."""
    body = getattr(exc, "body", None)
    if isinstance(body, dict):
        message = body.get("message") or (body.get("error") or {}).get("message")
        if message:
            return str(message)
    response = getattr(exc, "response", None)
    text = getattr(response, "text", None)
    return str(text if text else exc)


def _reply(response: Any, where: str) -> ChatReply:
    """The first choice of a chat completion, or the typed error saying what came instead:
    a body that is not JSON (an HTML page), no choices, or a refusal."""
    if isinstance(response, str | bytes):
        text = response.decode("utf-8", "replace") if isinstance(response, bytes) else response
        kind = "an HTML page" if text.lstrip()[:1] == "<" else "not JSON"
        raise VLMReplyError(f"{where} answered with {kind}: {text.strip()[:120]!r}", reason="json")
    choices = getattr(response, "choices", None) or []
    if not choices:
        raise VLMReplyError(f"{where} answered with no choices", reason="empty")
    choice = choices[0]
    refusal = getattr(choice.message, "refusal", None)
    if refusal:
        raise VLMRefusalError(str(refusal))
    content = getattr(choice.message, "content", None) or ""
    return ChatReply(content, choice.finish_reason, getattr(response, "model", None))


def _read_recording(path: Path) -> dict[str, deque[dict[str, Any]]]:
    out: dict[str, deque[dict[str, Any]]] = defaultdict(deque)
    try:
        lines = utf8_text(path.read_bytes()).splitlines()
    except ValueError as exc:
        raise VLMConfigError(f"{path}: not a recording: {exc}") from None
    for n, line in enumerate(lines, start=1):
        if not line.strip():
            continue
        try:
            entry = json.loads(line)
            out[entry["key"]].append(entry)
        except (json.JSONDecodeError, KeyError, TypeError) as exc:
            raise VLMConfigError(f"{path}:{n}: not a recorded exchange ({exc})") from exc
    return dict(out)


_ERRORS: dict[str, type[VLMError]] = {
    "VLMTimeoutError": VLMTimeoutError,
    "VLMTransportError": VLMTransportError,
    "VLMReplyError": VLMReplyError,
}


def _replayed(recording: dict[str, deque[dict[str, Any]]], key: str) -> ChatReply:
    entries = recording.get(key)
    if not entries:
        raise ReplayMissError(f"no recorded exchange for request {key[:12]}")
    entry = entries.popleft() if len(entries) > 1 else entries[0]
    if "error" in entry:
        err = entry["error"]
        kind = _ERRORS.get(err.get("type", ""), VLMTransportError)
        if kind is VLMReplyError:
            raise VLMReplyError(err.get("message", ""), reason="recorded")
        raise kind(err.get("message", ""), status=err.get("status"))
    reply = entry["reply"]
    return ChatReply(reply["content"], reply.get("finish_reason"), reply.get("model"))
