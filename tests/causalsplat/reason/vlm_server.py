"""A scripted OpenAI-compatible chat-completions server on loopback, for the VLM tests.

It speaks the real HTTP API (``POST /v1/chat/completions``) and answers each request with
the next scripted action: a reply, an HTTP status (with a Retry-After), a refusal, a body
that is no chat completion (an HTML page), or a delay before replying (to make the
client time out). Requests are kept for inspection. It reproduces what real servers do:

* **Token budget**: a reply longer than the request's ``max_tokens`` is cut there and comes
  back with ``finish_reason: "length"`` (tokens: words and punctuation marks, a stand-in
  for a real tokenizer).
* **Strict mode**: like OpenAI, a request whose ``response_format`` has ``strict: true``
  and a schema that breaks strict-mode rules (:func:`strict_schema_problems`) is refused
  with HTTP 400 and an ``invalid_request_error`` naming the problem (``strict=False``
  turns this off).
* **A model that keeps counting** (:class:`Counting`): it lists ids 0, 1, 2, ... until the
  budget cuts it off, unless the request's schema bounds ``target_ids`` with ``maxItems``,
  which a grammar-constrained server (llama.cpp, vLLM) enforces: then it stops there and
  closes the object.
* **A model that fills every field** (:class:`Filling`), as SmolLM2-135M does under
  llama.cpp's grammar: every property present (strict mode), arrays at their ``maxItems``,
  strings at their longest, as many steps as the schema allows. Whether that fits a token
  budget depends only on the schema's bounds.

Run as a program it serves on its own (``.ci/wheel-check`` asks an installed wheel's CLI
through it): ``python tests/causalsplat/reason/vlm_server.py --reply FILE [--times N]
[--requests FILE]`` prints its base URL as the first line on stdout, answers the first
``N`` requests (default 1) with the content of ``--reply`` and later ones with HTTP 500,
and on SIGTERM or SIGINT stops and writes the requests it received to ``--requests``
(a JSON list of ``{"path", "body"}``).
"""

from __future__ import annotations

import argparse
import json
import re
import signal
import sys
import threading
from collections import deque
from dataclasses import dataclass
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any


@dataclass(frozen=True)
class Reply:
    content: str
    finish_reason: str = "stop"
    delay_s: float = 0.0


@dataclass(frozen=True)
class Status:
    code: int
    retry_after: str | None = None  # the Retry-After header, when given


@dataclass(frozen=True)
class Raw:
    """A body that is not a chat completion (an HTML error page from a proxy...)."""

    body: bytes
    content_type: str = "text/html"
    code: int = 200


@dataclass(frozen=True)
class Refusal:
    """The model refuses (OpenAI's ``message.refusal``, content null)."""

    text: str


@dataclass(frozen=True)
class Counting:
    """A reply that writes ``program`` and ``explanation``, then keeps counting ids."""

    program: dict[str, Any]
    explanation: str = "counting"


@dataclass(frozen=True)
class Filling:
    """A reply that fills the request's schema to every bound (module docstring)."""


_TOKEN = re.compile(r"\w+|[^\w\s]")


def count_tokens(text: str) -> int:
    return len(_TOKEN.findall(text))


def cut_to_budget(content: str, max_tokens: int | None) -> tuple[str, bool]:
    """``content`` cut after its ``max_tokens``-th token, and whether it was cut."""
    if max_tokens is None:
        return content, False
    tokens = list(_TOKEN.finditer(content))
    if len(tokens) <= max_tokens:
        return content, False
    return content[: tokens[max_tokens - 1].end()], True


def _target_ids_bound(body: dict[str, Any]) -> int | None:
    schema = body.get("response_format", {}).get("json_schema", {}).get("schema", {})
    bound = schema.get("properties", {}).get("target_ids", {}).get("maxItems")
    return bound if isinstance(bound, int) else None


def counting_content(action: Counting, body: dict[str, Any]) -> str:
    """What the counting model writes for this request (before the budget cuts it)."""
    bound = _target_ids_bound(body)
    head = json.dumps({"program": action.program, "explanation": action.explanation})[:-1]
    n = bound if bound is not None else 100_000
    ids = ", ".join(str(i) for i in range(n))
    return f'{head}, "target_ids": [{ids}]}}'


_PATTERN_BOUND = re.compile(r"\{(\d+),(\d+)\}\$$")
#: What a model writes when a schema leaves a length open.
_OPEN_ARRAY, _OPEN_STRING = 64, 512


def filled(schema: dict[str, Any]) -> Any:
    """The largest value ``schema`` admits: strings of 3-letter words (about a token per 4
    characters, as real tokenizers go), numbers with 16 digits, arrays at ``maxItems``."""
    if "anyOf" in schema:
        return filled(next(s for s in schema["anyOf"] if s.get("type") != "null"))
    kind = schema.get("type")
    if kind == "object":
        return {name: filled(sub) for name, sub in schema.get("properties", {}).items()}
    if kind == "array":
        return [filled(schema["items"])] * int(schema.get("maxItems", _OPEN_ARRAY))
    if kind == "string":
        if "enum" in schema:
            return max(schema["enum"], key=len)
        match = _PATTERN_BOUND.search(schema.get("pattern", ""))
        length = int(match.group(2)) if match else int(schema.get("maxLength", _OPEN_STRING))
        return ("abc " * length)[:length]
    if kind == "integer":
        return int(schema.get("maximum", 10**15))
    if kind == "number":
        return 1.234567890123456
    return None


def filling_content(body: dict[str, Any]) -> str:
    schema = body.get("response_format", {}).get("json_schema", {}).get("schema", {})
    return json.dumps(filled(schema), indent=2)


# -- OpenAI's strict mode ----------------------------------------------------------------

#: Keywords OpenAI's structured outputs accept in strict mode (its "supported schemas"
#: guide): no minLength/maxLength, no oneOf/allOf/not, no patternProperties...
STRICT_KEYWORDS = frozenset(
    {
        "type", "description", "title", "properties", "required", "additionalProperties",
        "items", "enum", "const", "anyOf", "$ref", "$defs",
        "pattern", "format",
        "minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum", "multipleOf",
        "minItems", "maxItems",
    }
)  # fmt: skip
#: The guide's limits when strict mode came out: nesting depth and properties in all.
STRICT_MAX_DEPTH = 5
STRICT_MAX_PROPERTIES = 100


def strict_schema_problems(schema: dict[str, Any]) -> list[str]:
    """Why OpenAI's strict mode would refuse ``schema`` (empty: it is accepted).

    Every object must have ``additionalProperties: false`` and list every property in
    ``required``; only :data:`STRICT_KEYWORDS`; the root is an object, not ``anyOf``;
    objects nest at most :data:`STRICT_MAX_DEPTH` deep, with at most
    :data:`STRICT_MAX_PROPERTIES` properties in all. Walks ``properties``, ``items``,
    ``anyOf`` and ``$defs``.
    """
    problems: list[str] = []
    if schema.get("type") != "object" or "anyOf" in schema:
        problems.append("the root must be an object, not anyOf")
    counted = [0]
    _walk_strict(schema, "$", 1, problems, counted)
    for name, sub in schema.get("$defs", {}).items():
        _walk_strict(sub, f"$defs.{name}", 1, problems, counted)
    if counted[0] > STRICT_MAX_PROPERTIES:
        problems.append(f"{counted[0]} object properties (at most {STRICT_MAX_PROPERTIES})")
    return problems


def _walk_strict(node: Any, path: str, depth: int, problems: list[str], counted: list[int]) -> None:
    if not isinstance(node, dict):
        problems.append(f"{path}: not a schema object")
        return
    unsupported = sorted(set(node) - STRICT_KEYWORDS)
    if unsupported:
        problems.append(f"{path}: {', '.join(repr(k) for k in unsupported)} is not permitted")
    types = node.get("type")
    is_object = types == "object" or (isinstance(types, list) and "object" in types)
    if is_object or "properties" in node:
        if depth > STRICT_MAX_DEPTH:
            problems.append(f"{path}: nested {depth} objects deep (at most {STRICT_MAX_DEPTH})")
        properties = node.get("properties", {})
        counted[0] += len(properties)
        if node.get("additionalProperties") is not False:
            problems.append(f"{path}: 'additionalProperties' is required to be false")
        required = node.get("required")
        if not isinstance(required, list) or set(required) != set(properties):
            missing = sorted(set(properties) - set(required or []))
            problems.append(
                f"{path}: 'required' is required to be supplied and to be an array including"
                f" every key in properties. Missing {missing}"
            )
        for name, sub in properties.items():
            _walk_strict(sub, f"{path}.{name}", depth + 1, problems, counted)
    if "items" in node:
        _walk_strict(node["items"], f"{path}[]", depth, problems, counted)
    for i, sub in enumerate(node.get("anyOf", [])):
        _walk_strict(sub, f"{path}.anyOf[{i}]", depth, problems, counted)


def _strict_refusal(body: dict[str, Any]) -> str | None:
    """OpenAI's 400 message for a strict ``json_schema`` it cannot use, or ``None``."""
    fmt = body.get("response_format") or {}
    wrapper = fmt.get("json_schema") or {}
    if fmt.get("type") != "json_schema" or wrapper.get("strict") is not True:
        return None
    problems = strict_schema_problems(wrapper.get("schema") or {})
    if not problems:
        return None
    return f"Invalid schema for response_format '{wrapper.get('name')}': {problems[0]}."


# -- the server --------------------------------------------------------------------------


class ScriptedServer:
    """The server (module docstring); ``strict``: refuse strict schemas OpenAI refuses."""

    def __init__(
        self, *, strict: bool = True, budget_param: str = "max_tokens", temperature: bool = True
    ) -> None:
        """``budget_param``: the token budget parameter the model takes (OpenAI's reasoning
        models refuse ``max_tokens`` and take ``max_completion_tokens``); ``temperature``:
        whether it takes a temperature other than its default (they do not)."""
        self.script: deque[Reply | Status | Counting | Filling | Raw | Refusal] = deque()
        self.requests: list[dict[str, Any]] = []
        self.strict = strict
        self.budget_param = budget_param
        self.temperature = temperature
        self.released = threading.Event()  # set on exit: a delayed reply stops waiting
        server = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *_args: object) -> None:
                pass

            def do_POST(self) -> None:
                length = int(self.headers.get("Content-Length", "0"))
                body = json.loads(self.rfile.read(length) or b"{}")
                record: dict[str, Any] = {"path": self.path, "body": body}
                server.requests.append(record)
                refusal = _strict_refusal(body) if server.strict else None
                if refusal is not None:
                    error = {
                        "message": refusal,
                        "type": "invalid_request_error",
                        "param": "response_format",
                        "code": None,
                    }
                    self._send(400, {"error": error})
                    return
                unsupported = _unsupported(body, server.budget_param, server.temperature)
                if unsupported is not None:
                    self._send(400, {"error": unsupported})
                    return
                action = server.script.popleft() if server.script else Status(500)
                if isinstance(action, Status):
                    extra = (
                        {} if action.retry_after is None else {"Retry-After": action.retry_after}
                    )
                    self._send(action.code, {"error": {"message": "scripted failure"}}, extra)
                    return
                if isinstance(action, Raw):
                    self._send_bytes(action.code, action.body, action.content_type)
                    return
                if isinstance(action, Refusal):
                    document = _completion(body, "", "stop")
                    message = document["choices"][0]["message"]
                    message["content"], message["refusal"] = None, action.text
                    self._send(200, document)
                    return
                if isinstance(action, Counting):
                    action = Reply(counting_content(action, body))
                elif isinstance(action, Filling):
                    action = Reply(filling_content(body))
                if action.delay_s:
                    server.released.wait(action.delay_s)  # cut short when the server stops
                budget = body.get("max_tokens", body.get("max_completion_tokens"))
                content, cut = cut_to_budget(action.content, budget)
                finish = "length" if cut else action.finish_reason
                record["finish_reason"] = finish
                self._send(200, _completion(body, content, finish))

            def _send(
                self, code: int, document: dict[str, Any], headers: dict[str, str] | None = None
            ) -> None:
                self._send_bytes(code, json.dumps(document).encode(), "application/json", headers)

            def _send_bytes(
                self, code: int, data: bytes, content_type: str,
                headers: dict[str, str] | None = None,
            ) -> None:  # fmt: skip
                try:
                    self.send_response(code)
                    self.send_header("Content-Type", content_type)
                    self.send_header("Content-Length", str(len(data)))
                    for name, value in (headers or {}).items():
                        self.send_header(name, value)
                    self.end_headers()
                    self.wfile.write(data)
                except (BrokenPipeError, ConnectionResetError):
                    pass  # the client gave up (timeout test)

        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.httpd.daemon_threads = True
        self.thread = threading.Thread(target=self.httpd.serve_forever, daemon=True)

    @property
    def base_url(self) -> str:
        host, port = self.httpd.server_address[:2]
        return f"http://{host}:{port}/v1"

    def bodies(self) -> list[dict[str, Any]]:
        """The JSON bodies of the requests received, in order."""
        return [r["body"] for r in self.requests]

    def __enter__(self) -> ScriptedServer:
        self.thread.start()
        return self

    def __exit__(self, *_exc: object) -> None:
        self.released.set()
        self.httpd.shutdown()
        self.httpd.server_close()


def _unsupported(
    body: dict[str, Any], budget_param: str, temperature: bool
) -> dict[str, Any] | None:
    """OpenAI's 400 error for a parameter a reasoning model refuses, or ``None``."""
    if budget_param == "max_completion_tokens" and "max_tokens" in body:
        return {
            "message": "Unsupported parameter: 'max_tokens' is not supported with this model."
            " Use 'max_completion_tokens' instead.",
            "type": "invalid_request_error", "param": "max_tokens", "code": "unsupported_parameter",
        }  # fmt: skip
    if not temperature and body.get("temperature", 1) != 1:
        return {
            "message": f"Unsupported value: 'temperature' does not support"
            f" {body['temperature']} with this model. Only the default (1) value is supported.",
            "type": "invalid_request_error", "param": "temperature", "code": "unsupported_value",
        }  # fmt: skip
    return None


def _completion(body: dict[str, Any], content: str, finish_reason: str) -> dict[str, Any]:
    used = count_tokens(content)
    return {
        "id": "chatcmpl-test",
        "object": "chat.completion",
        "created": 0,
        "model": body.get("model", "test-model"),
        "choices": [
            {
                "index": 0,
                "message": {"role": "assistant", "content": content},
                "finish_reason": finish_reason,
            }
        ],
        "usage": {"prompt_tokens": 1, "completion_tokens": used, "total_tokens": used + 1},
    }


def main(argv: list[str] | None = None) -> None:
    """Serve scripted replies until SIGTERM or SIGINT (module docstring)."""
    parser = argparse.ArgumentParser(description="A scripted OpenAI-compatible server.")
    parser.add_argument("--reply", required=True, help="file whose text is every reply")
    parser.add_argument("--times", type=int, default=1, help="requests to answer (then 500)")
    parser.add_argument("--requests", help="JSON file for the requests received, on exit")
    args = parser.parse_args(argv)
    with open(args.reply, encoding="utf-8") as f:
        content = f.read()
    stop = threading.Event()
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: stop.set())
    with ScriptedServer() as server:
        server.script.extend([Reply(content)] * args.times)
        print(server.base_url, flush=True)
        stop.wait()
    if args.requests:
        with open(args.requests, "w", encoding="utf-8") as f:
            json.dump(server.requests, f)


if __name__ == "__main__":
    sys.exit(main())
