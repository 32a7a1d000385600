"""The JSON API and the static files of ``causalsplat serve``, through a real HTTP server."""

from __future__ import annotations

import json
import subprocess
import sys
from urllib.parse import quote

import numpy as np
import pytest

from causalsplat import open_store
from causalsplat.serve import App, ServeError, Server
from causalsplat.serve.static import STATIC_DIR
from tests.causalsplat.serve._client import request
from tests.causalsplat.serve.conftest import LABELS
from tests.conftest import COMMAND_TIMEOUT_S, REPO_ROOT

KITCHEN = "demo-kitchen"
LABELLED = quote("labelled kitchen")
TABLE_FALLS = {
    "query_type": "counterfactual",
    "steps": [
        {"op": "scene"},
        {"op": "filter_category", "inputs": [0], "value": "table"},
        {"op": "fall_if_removed", "inputs": [1]},
    ],
    "answer_step": 2,
}


def test_scenes_lists_every_stored_scene_with_its_counts(base_url: str) -> None:
    reply = request(f"{base_url}/api/scenes")
    assert reply.status == 200
    scenes = {s["scene_id"]: s for s in reply.json()["scenes"]}
    assert set(scenes) == {KITCHEN, "labelled kitchen"}
    kitchen = scenes[KITCHEN]
    assert (kitchen["entities"], kitchen["source"], kitchen["units"], kitchen["up_axis"]) == (
        12, "objects", "m", "z")  # fmt: skip
    assert kitchen["relations"] > 0


def test_a_scene_has_its_meta_entities_and_relations(base_url: str, store_url: str) -> None:
    doc = request(f"{base_url}/api/scenes/{KITCHEN}").json()
    with open_store(store_url, create=False) as store:
        graph = store.scene(KITCHEN).graph
    assert doc["scene_id"] == KITCHEN and doc["meta"]["up_axis"] == "z"
    assert [e["id"] for e in doc["entities"]] == [e.id for e in graph.entities]
    towel = next(e for e in doc["entities"] if e["category"] == "towel")
    assert towel["color"] == "blue"
    assert {"key": "material", "value": "cotton", "source": "input"} in towel["attributes"]
    entity = graph.get_entity(towel["id"])
    assert (towel["centroid"], towel["bbox_min"], towel["bbox_max"]) == (
        list(entity.centroid), list(entity.bbox_min), list(entity.bbox_max))  # fmt: skip
    got = {(r["subject"], r["predicate"], r["object"]) for r in doc["relations"]}
    assert got == {(r.src, r.type.value, r.dst) for r in graph.relations}


def test_entities_and_relations_routes(base_url: str) -> None:
    entities = request(f"{base_url}/api/scenes/{KITCHEN}/entities").json()["entities"]
    sink = next(e for e in entities if e["category"] == "sink")
    one = request(f"{base_url}/api/scenes/{KITCHEN}/entities/{sink['id']}").json()
    assert one["entity"] == sink
    assert one["relations"] and all(sink["id"] in (r["subject"], r["object"])
                                    for r in one["relations"])  # fmt: skip
    above = request(f"{base_url}/api/scenes/{KITCHEN}/relations?predicate=supported_by").json()
    assert above["relations"] and {r["predicate"] for r in above["relations"]} == {"supported_by"}
    assert request(f"{base_url}/api/scenes/{KITCHEN}/entities/999").status == 404
    assert request(f"{base_url}/api/scenes/{KITCHEN}/entities/x").status == 400
    bad = request(f"{base_url}/api/scenes/{KITCHEN}/relations?predicate=abov")
    assert bad.status == 400 and "abov" in bad.json()["error"]


def test_labels_are_little_endian_int32_with_a_count(base_url: str) -> None:
    reply = request(f"{base_url}/api/scenes/{LABELLED}/labels")
    assert reply.status == 200 and reply.content_type == "application/octet-stream"
    assert reply.headers["x-count"] == str(len(LABELS))
    assert np.array_equal(np.frombuffer(reply.body, dtype="<i4"), LABELS)
    missing = request(f"{base_url}/api/scenes/{KITCHEN}/labels")
    assert missing.status == 404 and "no per-Gaussian labels" in missing.json()["error"]


def test_ask_answers_as_the_ask_command_does(base_url: str, store_url: str) -> None:
    question = "where can I heat up my food?"
    reply = request(f"{base_url}/api/scenes/{KITCHEN}/ask", method="POST",
                    json_body={"question": question, "reasoner": "offline"})  # fmt: skip
    assert reply.status == 200
    doc = reply.json()
    cli = subprocess.run(
        [sys.executable, "-m", "causalsplat", "ask", question, "--scene", KITCHEN, "--json",
         "--db", store_url],
        capture_output=True, text=True, cwd=REPO_ROOT, timeout=COMMAND_TIMEOUT_S, check=True,
    )  # fmt: skip
    assert doc == json.loads(cli.stdout)
    assert [e["category"] for e in doc["entities"]] == ["microwave"]
    assert doc["program_text"] and doc["explanation"] and doc["candidates"]


@pytest.mark.parametrize("executor", ["sql", "networkx", "sparql"])
def test_query_runs_a_structured_program(base_url: str, executor: str) -> None:
    reply = request(f"{base_url}/api/scenes/{KITCHEN}/query", method="POST",
                    json_body={**TABLE_FALLS, "executor": executor})  # fmt: skip
    assert reply.status == 200
    doc = reply.json()
    assert doc["executor"] == executor
    assert sorted(e["category"] for e in doc["entities"]) == ["book", "cup"]
    assert doc["answer"] == sorted(e["id"] for e in doc["entities"])


@pytest.mark.parametrize(
    ("path", "body", "status", "words"),
    [
        ("ask", b'{"question": 3}', 400, "question"),
        ("ask", b'{"question": "the sink", "reasoner": "oracle"}', 400, "oracle"),
        ("ask", b"not json", 400, "not valid JSON"),
        ("ask", b"[1]", 400, "JSON object"),
        ("ask", b'{"question": "the sink", "k": 1' + b"0" * 5000 + b"}", 400, "4300 digits"),
        ("query", b'{"query_type": "nope", "steps": []}', 400, "query_type"),
        ("query", json.dumps({**TABLE_FALLS, "executor": "magic"}).encode(), 400, "magic"),
    ],
)
def test_bad_requests_are_400_with_one_line(
    base_url: str, path: str, body: bytes, status: int, words: str
) -> None:
    reply = request(f"{base_url}/api/scenes/{KITCHEN}/{path}", method="POST", body=body,
                    headers={"Content-Type": "application/json"})  # fmt: skip
    assert reply.status == status
    error = reply.json()["error"]
    assert words in error and "\n" not in error


@pytest.mark.parametrize(
    "content_type", ["text/plain", "application/x-www-form-urlencoded", "multipart/form-data", None]
)
def test_api_posts_take_json_bodies_only(base_url: str, content_type: str | None) -> None:
    # the bodies a page of another origin may send without a preflight: refused, not run
    headers = {} if content_type is None else {"Content-Type": content_type}
    reply = request(f"{base_url}/api/scenes/{KITCHEN}/ask", method="POST",
                    body=b'{"question": "the sink"}', headers=headers)  # fmt: skip
    assert reply.status == 415
    assert "application/json" in reply.json()["error"]


def test_unknown_scene_path_and_method(base_url: str) -> None:
    assert request(f"{base_url}/api/scenes/nope").status == 404
    assert "no scene 'nope'" in request(f"{base_url}/api/scenes/nope").json()["error"]
    assert request(f"{base_url}/api/nothing").status == 404
    reply = request(f"{base_url}/api/scenes", method="DELETE")
    assert reply.status == 405 and reply.headers["allow"] == "GET"
    assert request(f"{base_url}/api/scenes/{KITCHEN}/ask").status == 405


def test_static_files_are_served_from_the_package_folder_only(base_url: str) -> None:
    index = request(f"{base_url}/")
    assert index.status == 200 and index.content_type.startswith("text/html")
    assert b"/sparql" in index.body or (STATIC_DIR / "index.html").is_file()
    for path in ("../app.py", "..%2Fapp.py", "%2e%2e/app.py", "a/../../app.py", "nothing.js",
                 "%00.js", "..\\app.py"):  # fmt: skip
        assert request(f"{base_url}/static/{path}").status == 404, path
    gitkeep = request(f"{base_url}/static/.gitkeep")
    assert gitkeep.status == 200 and gitkeep.body == (STATIC_DIR / ".gitkeep").read_bytes()


def test_static_media_types() -> None:
    from pathlib import Path

    from causalsplat.serve.static import media_type

    assert media_type(Path("a.js")).startswith("text/javascript")
    assert media_type(Path("a.wasm")) == "application/wasm"
    assert media_type(Path("a.css")).startswith("text/css")
    assert media_type(Path("a.html")).startswith("text/html")


def test_a_host_that_is_not_loopback_is_refused(store_url: str) -> None:
    with open_store(store_url, create=False) as store:
        app = App(store)
        for host in ("0.0.0.0", "::", "192.0.2.1"):
            with pytest.raises(ServeError, match="--allow-remote"):
                Server(app, host, 0)
        with Server(app, "::1" if _has_ipv6() else "localhost", 0).start() as server:
            assert request(f"{server.url}api/scenes").status == 200


def _has_ipv6() -> bool:
    import socket

    try:
        with socket.socket(socket.AF_INET6) as s:
            s.bind(("::1", 0))
    except OSError:
        return False
    return True


def test_a_request_for_another_host_name_is_refused(base_url: str) -> None:
    """DNS rebinding: a page whose name now points at 127.0.0.1 sends its own name."""
    refused = request(f"{base_url}/api/scenes", headers={"Host": "attacker.example:80"})
    assert refused.status == 403 and "loopback" in refused.json()["error"]
    port = base_url.rsplit(":", 1)[1]
    for host in (f"localhost:{port}", f"127.0.0.1:{port}", f"[::1]:{port}"):
        assert request(f"{base_url}/api/scenes", headers={"Host": host}).status == 200
