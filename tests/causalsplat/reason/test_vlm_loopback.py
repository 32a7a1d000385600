"""The VLM backend against a real HTTP server on loopback that replays scripted replies.

Every case ends in a valid answer (from the VLM, or from the offline fallback, which the
answer says) or in a typed error; none needs a real model. The server behaves as real ones
do (``vlm_server``): it cuts replies at the request's ``max_tokens``, refuses schemas that
OpenAI's strict mode refuses, and can play a model that keeps counting ids.
"""

from __future__ import annotations

import base64
import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from causalsplat import Store
from causalsplat.cli import cli
from causalsplat.openai_compat import (
    ChatClient,
    ReplayMissError,
    VLMConfig,
    VLMConfigError,
    VLMLabeler,
    VLMReplyError,
    VLMTransportError,
    VLMTruncatedError,
    retry_budget,
)
from causalsplat.reason import SceneContext
from causalsplat.reason import vlm as vlm_module
from causalsplat.reason.vlm import (
    MAX_EXPLANATION_LENGTH,
    MAX_REPLY_STEPS,
    MAX_TARGET_IDS,
    VLMReasoner,
    reply_schema,
)
from queries import GraphQuery
from queries.schema import graph_query_strict_schema
from tests.causalsplat.reason.vlm_server import (
    Counting,
    Filling,
    Reply,
    ScriptedServer,
    Status,
    count_tokens,
    filled,
    strict_schema_problems,
)
from tests.conftest import COMMAND_TIMEOUT_S

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
    assert body["max_tokens"] == 1024
    fmt = body["response_format"]
    assert fmt["type"] == "json_schema" and fmt["json_schema"]["strict"] is True
    assert fmt["json_schema"]["schema"] == reply_schema()
    assert strict_schema_problems(reply_schema()) == []
    program = reply_schema()["properties"]["program"]
    assert program["properties"]["steps"]["maxItems"] == MAX_REPLY_STEPS
    assert program["properties"]["answer_step"]["maximum"] == MAX_REPLY_STEPS - 1
    assert reply_schema()["properties"]["target_ids"]["maxItems"] == MAX_TARGET_IDS
    user = body["messages"][1]["content"]
    assert "6 chair |" in user and "Instruction: the chair closest to the lamp" in user
    # the target is named outright: no scored candidates to choose among
    assert "Candidates for what the instruction asks for" in user


def test_the_prompt_carries_the_grounding_candidates(room: SceneContext) -> None:
    with ScriptedServer() as server:
        server.script.append(Reply(VALID))
        answer = reasoner(server).answer("where can I sit down?", room)
    user = server.requests[0]["body"]["messages"][1]["content"]
    block = user.split("best first:\n", 1)[1].split("\n\nInstruction:", 1)[0]
    first = block.splitlines()[0]
    assert first.startswith("chair ") and "ids [5, 6, 7]" in first and "chair: " in first
    assert answer.candidates and answer.candidates[0].category == "chair"
    # the VLM's program selected entity 6 (a chair): the chair candidate is marked chosen
    assert answer.entity_ids == (6,) and answer.candidates[0].chosen


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
        ([Reply(VALID, finish_reason="length")] * 2, "VLMTruncatedError"),
        ([Status(500)], "HTTP 500"),
        # held until the test ends: the client's 0.5 s always run out first
        ([Reply(VALID, delay_s=COMMAND_TIMEOUT_S)], "VLMTimeoutError"),
    ],
)
def test_failures_fall_back_to_the_offline_reasoner(
    room: SceneContext, script: list[Reply | Status], why: str
) -> None:
    # only the timeout case needs a short timeout: the others must get their replies
    timeout_s = 0.5 if why == "VLMTimeoutError" else 60.0
    with ScriptedServer() as server:
        server.script.extend(script)
        answer = reasoner(server, timeout_s=timeout_s).answer(TEXT, room)
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


# -- what real servers do: token budgets, strict mode, a model that keeps counting -------


def valid_reply(explanation_words: int) -> str:
    """VALID with an explanation of that many words (one token each)."""
    explanation = " ".join(["word"] * explanation_words)
    return json.dumps({"program": PROGRAM, "target_ids": [6], "explanation": explanation})


def test_cut_off_reply_is_retried_with_a_bigger_budget(room: SceneContext) -> None:
    long = valid_reply(1500)
    assert 1024 < count_tokens(long) <= 2048
    with ScriptedServer() as server:
        server.script.extend([Reply(long), Reply(long)])  # the model writes the same again
        answer = reasoner(server).answer(TEXT, room)
    assert answer.reasoner == "vlm" and answer.fallback is None and answer.entity_ids == (6,)
    assert "first reply rejected (truncated)" in answer.explanation
    first, second = server.bodies()
    assert (first["max_tokens"], second["max_tokens"]) == (1024, 2048)
    # The retry asks again (no cut-off text sent back, roles still alternate) and says why.
    assert [m["role"] for m in second["messages"]] == ["system", "user"]
    assert "cut off after 1024 tokens" in feedback(server, 1)
    assert "shorter" in feedback(server, 1)
    # The explanation is kept to the schema's bound.
    said = next(line for line in answer.explanation.splitlines() if line.startswith("the model:"))
    assert len(said) <= len("the model: ") + MAX_EXPLANATION_LENGTH


def test_cut_off_twice_falls_back_and_says_so(room: SceneContext) -> None:
    longer = valid_reply(3000)
    with ScriptedServer() as server:
        server.script.extend([Reply(longer)] * 2)
        answer = reasoner(server).answer(TEXT, room)
        assert [b["max_tokens"] for b in server.bodies()] == [1024, 2048]
        server.script.extend([Reply(longer)] * 2)
        with pytest.raises(VLMTruncatedError) as info:
            reasoner(server, fallback=False).answer(TEXT, room)
    assert answer.reasoner == "offline" and answer.fallback is not None
    assert answer.fallback.startswith("VLMTruncatedError: the reply was cut off at max_tokens=2048")
    assert "the first reply: the reply was cut off at max_tokens=1024" in answer.fallback
    assert info.value.max_tokens == 2048 and info.value.reason == "truncated"


def test_retry_budget_doubles_up_to_a_cap() -> None:
    assert [retry_budget(n) for n in (1, 1024, 6000, 8192, 20000)] == [2, 2048, 8192, 8192, 20000]


def test_a_model_that_keeps_counting_is_bounded_by_the_schema(room: SceneContext) -> None:
    with ScriptedServer() as server:
        # Without a bound on target_ids (the old schema), it runs into the budget.
        server.script.append(Counting(PROGRAM))
        client = ChatClient(VLMConfig(base_url=server.base_url, model="m", max_tokens=300))
        loose = {"type": "json_schema", "json_schema": {"name": "x", "schema": {}}}
        assert client.complete([{"role": "user", "content": TEXT}],
                               response_format=loose).finish_reason == "length"  # fmt: skip
        # With the reply schema, the grammar stops it at maxItems: a complete reply, whose
        # made-up ids are fed back; the retry is answered properly.
        server.script.extend([Counting(PROGRAM), Reply(VALID)])
        answer = reasoner(server).answer(TEXT, room)
    assert answer.reasoner == "vlm" and answer.entity_ids == (6,)
    assert "first reply rejected (unknown_id)" in answer.explanation
    assert "are not entities of the scene" in feedback(server, 2)
    counted = json.loads(server.requests[2]["body"]["messages"][-2]["content"])
    assert len(counted["target_ids"]) == MAX_TARGET_IDS


def test_a_model_that_fills_every_field_fits_the_retry_budget(room: SceneContext) -> None:
    """SmolLM2-135M under llama.cpp's grammar fills every step of every allowed step: with
    the query language's own bounds (64 steps, 512-character values) such a reply is cut
    off at 1024 tokens and again at the retry's 2048; with the reply's bounds it ends."""
    loose = reply_schema()
    loose["properties"]["program"] = graph_query_strict_schema()
    assert count_tokens(json.dumps(filled(loose), indent=2)) > 2048
    worst = count_tokens(json.dumps(filled(reply_schema()), indent=2))
    assert worst <= 2048, worst  # whole within the retry's budget at the latest
    with ScriptedServer() as server:
        server.script.extend([Filling(), Filling()])
        answer = reasoner(server).answer(TEXT, room)
    finishes = [r["finish_reason"] for r in server.requests]
    assert len(finishes) == 2 and finishes[1] == "stop", finishes
    # the whole reply is made-up ids and words: refused for what it says, not for its size
    assert answer.fallback is not None and "Truncated" not in answer.fallback


def test_too_many_target_ids_are_refused(room: SceneContext) -> None:
    many = json.dumps({"program": PROGRAM, "target_ids": [6] * 40, "explanation": ""})
    with ScriptedServer() as server:
        server.script.extend([Reply(many), Reply(VALID)])
        answer = reasoner(server).answer(TEXT, room)
    assert answer.reasoner == "vlm" and "first reply rejected (schema)" in answer.explanation
    assert f"at most {MAX_TARGET_IDS}" in feedback(server, 1)


def test_strict_server_accepts_the_reply_schema_and_refuses_the_flat_one(
    room: SceneContext, monkeypatch: pytest.MonkeyPatch
) -> None:
    with ScriptedServer(strict=True) as server:
        server.script.append(Reply(VALID))
        assert reasoner(server).answer(TEXT, room).reasoner == "vlm"
        # The flat program schema (optional properties, maxLength) sent with strict: true
        # is refused the way OpenAI refuses it: HTTP 400, and the answer says so.
        flat = {"type": "object", "properties": {"program": GraphQuery.json_schema()},
                "required": ["program"], "additionalProperties": False}  # fmt: skip
        old = {
            "type": "json_schema",
            "json_schema": {"name": "old", "schema": flat, "strict": True},
        }
        monkeypatch.setattr(vlm_module, "response_format", lambda: old)
        server.script.append(Reply(VALID))
        answer = reasoner(server).answer(TEXT, room)
        assert len(server.script) == 1  # refused before any reply was generated
    assert answer.reasoner == "offline" and answer.fallback is not None
    assert "HTTP 400" in answer.fallback and "Invalid schema" in answer.fallback


def test_strict_replies_with_nulls_are_accepted(room: SceneContext) -> None:
    nulls = {"value": None, "relation": None, "metric": None, "k": None, "viewpoint": None}
    steps = [nulls | {"inputs": []} | s for s in PROGRAM["steps"]]  # type: ignore[attr-defined]
    reply = {"program": PROGRAM | {"steps": steps}, "target_ids": [6], "explanation": "x"}
    with ScriptedServer() as server:
        server.script.append(Reply(json.dumps(reply)))
        answer = reasoner(server).answer(TEXT, room)
    assert answer.reasoner == "vlm" and answer.program == GraphQuery.parse(PROGRAM)


# -- the CLI's token budget ----------------------------------------------------------------


@pytest.fixture
def no_vlm_env(monkeypatch: pytest.MonkeyPatch) -> pytest.MonkeyPatch:
    for var in ("BASE_URL", "MODEL", "API_KEY", "MAX_TOKENS"):
        monkeypatch.delenv(f"CAUSALSPLAT_VLM_{var}", raising=False)
    return monkeypatch


def vlm_args(store: Store, server: ScriptedServer) -> list[str]:
    return ["--scene", "synth-tiny-0", "--db", store.graph_store.url, "--reasoner", "vlm",
            "--base-url", server.base_url, "--model", "m", "--json"]  # fmt: skip


def test_max_tokens_reaches_the_request(
    tiny_store: Store, tiny_dir: Path, no_vlm_env: pytest.MonkeyPatch
) -> None:
    runner = CliRunner()
    with ScriptedServer() as server:
        server.script.extend([Reply("not json"), Reply("still not json")])
        ask = ["ask", "the table", *vlm_args(tiny_store, server)]
        result = runner.invoke(cli, [*ask, "--max-tokens", "77"])
        assert result.exit_code == 3, result.output  # answered, but not by the VLM
        assert json.loads(result.stdout)["fallback"]  # answered offline, and says so
        assert "pass --allow-fallback" in result.stderr
        assert [b["max_tokens"] for b in server.bodies()] == [77, 77]  # not cut off: same
        no_vlm_env.setenv("CAUSALSPLAT_VLM_MAX_TOKENS", "99")
        ask.append("--allow-fallback")
        assert runner.invoke(cli, ask).exit_code == 0
        assert runner.invoke(cli, [*ask, "--max-tokens", "55"]).exit_code == 0
        # 500 (empty script): not retried, one request per instruction.
        assert [b["max_tokens"] for b in server.bodies()[2:]] == [99, 55]
        server.requests.clear()
        queries = str(tiny_dir / "queries.json")
        result = runner.invoke(cli, ["eval", queries, *vlm_args(tiny_store, server),
                                     "--max-tokens", "640"])  # fmt: skip
        assert result.exit_code == 3, result.output  # every query fell back: said, not hidden
        assert "queries were answered by the offline reasoner" in result.stderr
        assert server.requests and {b["max_tokens"] for b in server.bodies()} == {640}


@pytest.mark.parametrize("value", ["0", "-3", "abc", "1.5", "", "2e3"])
@pytest.mark.parametrize("command", ["ask", "eval"])
def test_invalid_max_tokens_is_one_line(
    tiny_store: Store, tiny_dir: Path, no_vlm_env: pytest.MonkeyPatch, value: str, command: str
) -> None:
    first = ["ask", "the table"] if command == "ask" else ["eval", str(tiny_dir / "queries.json")]
    with ScriptedServer() as server:
        result = CliRunner().invoke(cli, [*first, *vlm_args(tiny_store, server),
                                          "--max-tokens", value])  # fmt: skip
    assert result.exit_code != 0 and not server.requests
    assert result.stderr.strip().splitlines() == [
        f"causalsplat: error: --max-tokens must be a positive integer, got {value!r}"
    ]
    assert result.stdout == ""


def test_invalid_max_tokens_variable_is_one_line(
    tiny_store: Store, no_vlm_env: pytest.MonkeyPatch
) -> None:
    no_vlm_env.setenv("CAUSALSPLAT_VLM_MAX_TOKENS", "lots")
    with ScriptedServer() as server:
        result = CliRunner().invoke(cli, ["ask", "the table", *vlm_args(tiny_store, server)])
    assert result.exit_code == 1 and len(result.stderr.strip().splitlines()) == 1
    assert "CAUSALSPLAT_VLM_MAX_TOKENS must be a positive integer, got 'lots'" in result.stderr
    with pytest.raises(VLMConfigError, match="positive"):
        VLMConfig(max_tokens=0)


def test_the_retry_repeats_a_rejected_reply_without_its_indentation(room: SceneContext) -> None:
    # SmolLM2 writes two-space indented JSON; repeated as written, a retry on a large
    # scene overflowed its 8,192-token context (docs/benchmarks.md)
    wrong = {"program": PROGRAM, "target_ids": [999], "explanation": "a chair"}
    with ScriptedServer() as server:
        server.script.extend([Reply(json.dumps(wrong, indent=2)), Reply(VALID)])
        answer = reasoner(server).answer(TEXT, room)
    assert answer.reasoner == "vlm" and answer.entity_ids == (6,)
    repeated = server.requests[1]["body"]["messages"][-2]
    assert repeated["role"] == "assistant"
    assert repeated["content"] == json.dumps(wrong) and "\n" not in repeated["content"]
    # a reply that is not JSON goes back as it was written
    with ScriptedServer() as server:
        server.script.extend([Reply("I think it is the chair.\n"), Reply(VALID)])
        reasoner(server).answer(TEXT, room)
    assert server.requests[1]["body"]["messages"][-2]["content"] == "I think it is the chair.\n"
