"""What real chat servers do besides answering, against the loopback server: busy (429/503
with Retry-After), a refusal, an HTML page where JSON belongs, a model that refuses
``max_tokens`` and any temperature but its default (OpenAI's reasoning models)."""

from __future__ import annotations

import json

import pytest

from causalsplat.openai_compat import (
    ChatClient,
    VLMConfig,
    VLMRefusalError,
    VLMReplyError,
    VLMTransportError,
)
from causalsplat.openai_compat import client as client_module
from causalsplat.reason import SceneContext
from causalsplat.reason.vlm import VLMReasoner
from tests.causalsplat.reason.vlm_server import Raw, Refusal, Reply, ScriptedServer, Status

pytestmark = pytest.mark.vlm

MESSAGES = [{"role": "user", "content": "hello"}]
PROGRAM = {
    "query_type": "spatial",
    "steps": [{"op": "scene"}, {"op": "filter_category", "inputs": [0], "value": "chair"}],
    "answer_step": 1,
}
VALID = json.dumps({"program": PROGRAM, "target_ids": [6], "explanation": "the chairs"})


def _client(server: ScriptedServer) -> ChatClient:
    return ChatClient(VLMConfig(base_url=server.base_url, model="m", api_key="k", timeout_s=10))


def test_a_busy_server_is_asked_again_after_the_wait_it_names(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    waits: list[float] = []
    monkeypatch.setattr(client_module.time, "sleep", waits.append)
    with ScriptedServer() as server:
        server.script.extend([Status(429, retry_after="2"), Status(503), Reply("ok")])
        reply = _client(server).complete(MESSAGES)
    assert reply.content == "ok" and len(server.requests) == 3
    assert waits == [2.0, 1.0]  # Retry-After, then the doubling wait of the second retry


def test_a_server_busy_for_good_is_an_error_naming_the_retries(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(client_module.time, "sleep", lambda _s: None)
    with ScriptedServer() as server:
        server.script.extend([Status(503)] * 5)
        with pytest.raises(VLMTransportError, match=r"HTTP 503 \(still busy after 3 retries\)"):
            _client(server).complete(MESSAGES)
    assert len(server.requests) == 1 + client_module.RETRIES


def test_a_wait_longer_than_the_cap_is_not_waited_for(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(client_module.time, "sleep", pytest.fail)
    with ScriptedServer() as server:
        server.script.append(Status(429, retry_after="3600"))
        with pytest.raises(VLMTransportError, match="HTTP 429"):
            _client(server).complete(MESSAGES)
    assert len(server.requests) == 1


def test_a_refusal_is_a_refusal_and_is_not_asked_again(room: SceneContext) -> None:
    with ScriptedServer() as server:
        server.script.extend([Refusal("I can't help with that."), Reply(VALID)])
        with pytest.raises(VLMRefusalError, match="the model refused: I can't help with that"):
            _client(server).complete(MESSAGES)
        server.script.appendleft(Refusal("I can't help with that."))
        config = VLMConfig(base_url=server.base_url, model="m", api_key="k", timeout_s=10)
        answer = VLMReasoner(config=config).answer("the chairs", room)
    assert answer.reasoner == "offline" and answer.fallback is not None
    assert answer.fallback.startswith("VLMRefusalError: the model refused")
    assert len(server.requests) == 2  # one each: a refusal is never retried


@pytest.mark.parametrize(
    ("raw", "words"),
    [
        (Raw(b"<!DOCTYPE html><html><body>502 Bad Gateway</body></html>"), "an HTML page"),
        (Raw(b"upstream connect error", content_type="text/plain"), "not JSON"),
    ],
)
def test_a_body_that_is_no_chat_completion_says_what_it_is(raw: Raw, words: str) -> None:
    with ScriptedServer() as server:
        server.script.append(raw)
        with pytest.raises(VLMReplyError, match=words):
            _client(server).complete(MESSAGES)


def test_a_model_that_takes_max_completion_tokens_and_its_default_temperature() -> None:
    with ScriptedServer(budget_param="max_completion_tokens", temperature=False) as server:
        server.script.extend([Reply("one"), Reply("two")])
        client = _client(server)
        assert client.complete(MESSAGES, max_tokens=50).content == "one"
        assert client.complete(MESSAGES, max_tokens=60).content == "two"
    bodies = server.bodies()
    assert len(bodies) == 4  # refused max_tokens, refused temperature, then two answers
    assert "max_tokens" in bodies[0] and "max_completion_tokens" in bodies[1]
    for body in bodies[2:]:  # the client keeps sending what the model takes
        assert "max_tokens" not in body and "temperature" not in body
    assert [b["max_completion_tokens"] for b in bodies[2:]] == [50, 60]
