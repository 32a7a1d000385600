"""The VLM backend against a real HTTP server on loopback that replays scripted replies.

Every case ends in a valid answer (from the VLM, or from the offline fallback, which the
answer says) or in a typed error; none needs a real model.
"""

from __future__ import annotations

import base64
import json
from pathlib import Path

import numpy as np
import pytest

from causalsplat.openai_compat import (
    ChatClient,
    ReplayMissError,
    VLMConfig,
    VLMConfigError,
    VLMLabeler,
    VLMReplyError,
    VLMTransportError,
)
from causalsplat.reason import SceneContext
from causalsplat.reason.vlm import VLMReasoner, reply_schema
from queries import GraphQuery
from tests.causalsplat.reason.vlm_server import Reply, ScriptedServer, Status

pytestmark = pytest.mark.vlm

TEXT = "the chair closest to the lamp"
PROGRAM = {
    "query_type": "spatial",
    "steps": [
        {"op": "scene"},
        {"op": "filter_category", "inputs": [0], "value": "chair"},
        {"op": "filter_category", "inputs": [0], "value": "lamp"},
        {"op": "argmin", "inputs": [1, 2], "metric": "distance"},
    ],
    "answer_step": 3,
}
VALID = json.dumps({"program": PROGRAM, "target_ids": [6], "explanation": "closest chair"})


def reasoner(server: ScriptedServer, **kwargs: object) -> VLMReasoner:
    timeout = float(kwargs.pop("timeout_s", 10.0))  # type: ignore[arg-type]
    config = VLMConfig(base_url=server.base_url, model="test-model", api_key="k", timeout_s=timeout)
    return VLMReasoner(config=config, **kwargs)  # type: ignore[arg-type]


def feedback(server: ScriptedServer, k: int) -> str:
    """The last message of the k-th request (the error fed back on a retry)."""
    return str(server.requests[k]["body"]["messages"][-1]["content"])


def test_valid_program(room: SceneContext) -> None:
    with ScriptedServer() as server:
        server.script.append(Reply(VALID))
        answer = reasoner(server).answer(TEXT, room)
    assert answer.reasoner == "vlm" and answer.fallback is None and answer.entity_ids == (6,)
    assert answer.program == GraphQuery.parse(PROGRAM)
    body = server.requests[0]["body"]
    assert server.requests[0]["path"] == "/v1/chat/completions"
    assert body["model"] == "test-model" and body["temperature"] == 0.0
    fmt = body["response_format"]
    assert fmt["type"] == "json_schema" and fmt["json_schema"]["schema"] == reply_schema()
    program_schema = dict(GraphQuery.json_schema())
    program_schema.pop("title")
    assert fmt["json_schema"]["schema"]["properties"]["program"] == program_schema
    user = body["messages"][1]["content"]
    assert "6 chair |" in user and "Instruction: the chair closest to the lamp" in user


@pytest.mark.parametrize(
    ("bad", "reason", "fed_back"),
    [
        (Reply("this is not json {"), "json", "not JSON"),
        (Reply(json.dumps({"program": {"query_type": "spatial", "steps": [{"op": "fly"}],
                                       "answer_step": 0}})), "schema", "step 0"),
        (Reply(json.dumps({"program": PROGRAM, "target_ids": [99], "explanation": ""})),
         "unknown_id", "[99]"),
        (Reply(VALID.replace('"lamp"', '"piano"')), "unknown_name", "'piano'"),
        (Reply(VALID[:40], finish_reason="length"), "truncated", "cut off"),
    ],
)  # fmt: skip
def test_one_bad_reply_is_retried(
    room: SceneContext, bad: Reply, reason: str, fed_back: str
) -> None:
    with ScriptedServer() as server:
        server.script.extend([bad, Reply(VALID)])
        answer = reasoner(server).answer(TEXT, room)
    assert answer.reasoner == "vlm" and answer.fallback is None and answer.entity_ids == (6,)
    assert f"first reply rejected ({reason})" in answer.explanation
    assert len(server.requests) == 2 and fed_back in feedback(server, 1)


@pytest.mark.parametrize(
    ("script", "why"),
    [
        ([Reply("nope"), Reply("still nope")], "VLMReplyError"),
        ([Reply(VALID.replace("[6]", "[99]"))] * 2, "not entities of the scene"),
        ([Reply(VALID, finish_reason="length")] * 2, "cut off"),
        ([Status(500)], "HTTP 500"),
        ([Reply(VALID, delay_s=2.0)], "VLMTimeoutError"),
    ],
)
def test_failures_fall_back_to_the_offline_reasoner(
    room: SceneContext, script: list[Reply | Status], why: str
) -> None:
    with ScriptedServer() as server:
        server.script.extend(script)
        answer = reasoner(server, timeout_s=0.5).answer(TEXT, room)
    assert answer.reasoner == "offline" and answer.requested == "vlm"
    assert answer.fallback is not None and why in answer.fallback
    assert answer.entity_ids == (6,)  # the offline reasoner gets this one right
    assert "the VLM failed" in answer.explanation


def test_without_fallback_errors_are_typed(room: SceneContext) -> None:
    with ScriptedServer() as server:
        server.script.append(Status(500))
        with pytest.raises(VLMTransportError) as info:
            reasoner(server, fallback=False).answer(TEXT, room)
        assert info.value.status == 500
        server.script.extend([Reply("x"), Reply("y")])
        with pytest.raises(VLMReplyError):
            reasoner(server, fallback=False).answer(TEXT, room)


def test_record_and_replay_round_trip(room: SceneContext, tmp_path: Path) -> None:
    log = tmp_path / "exchanges.jsonl"
    with ScriptedServer() as server:
        server.script.extend([Reply("not json"), Reply(VALID), Status(500)])
        recorded = reasoner(server, record=log).answer(TEXT, room)
        failed = reasoner(server, record=log).answer("the lamp", room)
    lines = [json.loads(line) for line in log.read_text().splitlines()]
    assert [("reply" in e, "error" in e) for e in lines] == [(1, 0), (1, 0), (0, 1)]
    assert all(len(e["key"]) == 64 and "api_key" not in json.dumps(e) for e in lines)
    # Replay: no server, same answers, the recorded failure fails again the same way.
    replayed = VLMReasoner(replay=log).answer(TEXT, room)
    assert replayed.reasoner == "vlm", replayed.fallback
    assert replayed.program == recorded.program
    assert replayed.entity_ids == recorded.entity_ids == (6,)
    again = VLMReasoner(replay=log).answer("the lamp", room)
    assert again.fallback is not None and failed.fallback is not None
    assert "HTTP 500" in again.fallback and "HTTP 500" in failed.fallback
    missed = VLMReasoner(replay=log).answer("the door", room)
    assert missed.reasoner == "offline" and "ReplayMissError" in (missed.fallback or "")
    with pytest.raises(ReplayMissError):
        VLMReasoner(replay=log, fallback=False).answer("the door", room)


def test_missing_settings_are_typed_errors(monkeypatch: pytest.MonkeyPatch) -> None:
    for var in ("CAUSALSPLAT_VLM_BASE_URL", "CAUSALSPLAT_VLM_MODEL"):
        monkeypatch.delenv(var, raising=False)
    with pytest.raises(VLMConfigError, match="CAUSALSPLAT_VLM_BASE_URL"):
        ChatClient()
    monkeypatch.setenv("CAUSALSPLAT_VLM_BASE_URL", "http://127.0.0.1:9/v1")
    with pytest.raises(VLMConfigError, match="CAUSALSPLAT_VLM_MODEL"):
        ChatClient()
    monkeypatch.setenv("CAUSALSPLAT_VLM_MODEL", "m")
    assert ChatClient().config.model == "m"


LABEL = json.dumps(
    {"category": "Chair", "color": "Red", "material": "", "state": "", "affordances": ["sit"]}
)


def test_labeler_sends_png_crops_and_parses_labels() -> None:
    crop = np.zeros((6, 8, 3), dtype=np.uint8)
    crop[2:4, 2:6] = (200, 30, 30)
    with ScriptedServer() as server:
        server.script.extend([Reply(LABEL), Reply("{}"), Reply(LABEL)])
        client = ChatClient(VLMConfig(base_url=server.base_url, model="vlm-test"))
        labels = VLMLabeler(client).label_crops([crop, crop], hints=["chair", None])
    assert labels[0] == labels[1]
    assert labels[0].category == "chair" and labels[0].attributes == (("color", "red"),)
    assert [(a.key, a.value, a.source.value) for a in labels[0].to_attributes()] == [
        ("affordance", "sit", "vlm"),
        ("color", "red", "vlm"),
    ]
    parts = server.requests[0]["body"]["messages"][1]["content"]
    assert "It may be a chair." in parts[0]["text"]
    url = parts[1]["image_url"]["url"]
    assert url.startswith("data:image/png;base64,")
    png = base64.b64decode(url.split(",", 1)[1])
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and png[16:24] == bytes([0, 0, 0, 8, 0, 0, 0, 6])
    assert "category" in feedback(server, 2)  # the retry after "{}" names what is missing
    with ScriptedServer() as server:
        server.script.extend([Reply("{}"), Reply("[]")])
        client = ChatClient(VLMConfig(base_url=server.base_url, model="vlm-test"))
        with pytest.raises(VLMReplyError):
            VLMLabeler(client).label_crops([crop])
