"""``causalsplat build`` through the real command line."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from tests.causalsplat.test_cli_store import assert_one_line_error, run


def test_build_json_report_then_query_the_stored_scene(tiny_folder: Path, tmp_path: Path) -> None:
    db = f"sqlite:///{tmp_path / 'b.db'}"
    config = tmp_path / "fast.json"
    config.write_text(json.dumps({"field": {"iterations": 40}}))
    # no --scene: the id the folder's queries.json declares
    args = ["build", str(tiny_folder), "--config", str(config),
            "--cache-dir", str(tmp_path / "cache")]  # fmt: skip
    doc = json.loads(run(*args, "--json", db=db).stdout)
    assert doc["scene_id"] == "synth-tiny-0" and doc["views"] == 12 and doc["entities"] >= 3
    assert [s["name"] for s in doc["stages"]] == ["load", "rasterize", "field", "instances",
                                                   "graph"]  # fmt: skip
    q = doc["quality"]
    assert doc["peak_rss_mib"] > 0 and q["n_gt"] > 0
    # panoptic figures beside mean best IoU, over GT objects of >= 50 Gaussians
    assert 0.0 <= q["pq"] <= q["rq"] <= 1.0 and q["panoptic_min_size"] == 50
    assert q["missed"] + q["extra"] >= 0 and q["split"] >= 0 and q["merged"] >= 0
    scenes = json.loads(run("scenes", "--json", db=db).stdout)
    assert [s["scene_id"] for s in scenes] == ["synth-tiny-0"] and scenes[0]["source"] == "build"
    # a second build of the same id fails and leaves the stored scene alone
    assert_one_line_error(run(*args, db=db, check=False), "already stored")
    text = run(*args, "--if-exists", "replace", db=db).stdout
    assert "(cached)" in text and "instance quality" in text and "PQ " in text
    ask = json.loads(run("ask", "where can I wash my hands?", "--scene", "synth-tiny-0", "--json",
                         db=db).stdout)  # fmt: skip
    # 40 training steps may leave a fragment of the sink as a second entity
    assert ask["entities"] and {e["category"] for e in ask["entities"]} == {"sink"}
    # the built scene scored against the folder's GT: targets are GT instance ids
    queries = json.loads((tiny_folder / "queries.json").read_text())["queries"]
    gt = str(tiny_folder / "gt" / "gt_labels.npy")
    doc = json.loads(run("eval", str(tiny_folder / "queries.json"), "--scene", "synth-tiny-0",
                         "--gt-labels", gt, "--json", db=db).stdout)  # fmt: skip
    assert doc["n"] == len(queries) and 0 < doc["accuracy"] <= 1 and 0 < doc["miou"] <= 1
    wash = next(q for q in doc["per_query"] if q["correct"])
    assert set(wash["predicted"]) == set(wash["targets"])
    # the entities' quality beside the answers': the same figures `build --json` reported
    built = json.loads(run(*args, "--if-exists", "replace", "--json", db=db).stdout)["quality"]
    for key in ("pq", "sq", "rq", "split", "merged", "missed", "extra", "mean_best_iou", "ap50"):
        assert doc["instances"][key] == built[key], key
    text = run("eval", str(tiny_folder / "queries.json"), "--scene", "synth-tiny-0",
               "--gt-labels", gt, db=db).stdout  # fmt: skip
    assert f"entities vs GT labels: {built['n_pred']} for {built['n_gt']} GT instances" in text
    assert f"PQ {built['pq']:.3f}" in text
    without = run("eval", str(tiny_folder / "queries.json"), "--scene", "synth-tiny-0", db=db,
                  check=False)  # fmt: skip
    assert_one_line_error(without, "is not in scene")
    assert "--gt-labels" in without.stderr
    short = tmp_path / "short.npy"
    np.save(short, np.zeros(3, dtype=np.int32))
    bad = run("eval", str(tiny_folder / "queries.json"), "--scene", "synth-tiny-0",
              "--gt-labels", str(short), db=db, check=False)  # fmt: skip
    assert_one_line_error(bad, "GT labels")


def test_build_errors_are_one_line_and_store_nothing(tiny_folder: Path, tmp_path: Path) -> None:
    db = f"sqlite:///{tmp_path / 'e.db'}"
    assert_one_line_error(run("build", str(tmp_path / "missing"), db=db, check=False),
                          "missing")  # fmt: skip
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"field": {"iters": 1}}))
    assert_one_line_error(
        run("build", str(tiny_folder), "--config", str(bad), db=db, check=False), "iters"
    )
    empty = tmp_path / "empty"
    empty.mkdir()
    assert_one_line_error(run("build", str(empty), "--no-cache", db=db, check=False), "PLY")
    nothing = tmp_path / "nothing.json"  # no cluster is big enough: no entity at all
    nothing.write_text(json.dumps({"field": {"iterations": 10},
                                   "instances": {"min_gaussians": 10**9}}))  # fmt: skip
    assert_one_line_error(run("build", str(tiny_folder), "--config", str(nothing), "--no-cache",
                              "--no-progress", db=db, check=False),
                          "the build found no entities")  # fmt: skip
    # with progress (the default off a terminal): stage lines, then the one error line
    proc = run("build", str(tiny_folder), "--config", str(nothing), "--no-cache", db=db,
               check=False)  # fmt: skip
    *before, last = proc.stderr.strip().splitlines()
    assert proc.returncode == 1 and last.startswith("causalsplat: error: ")
    assert "the build found no entities" in last and before
    assert all(line.startswith("causalsplat: ") and "error" not in line for line in before)
    if (tmp_path / "e.db").exists():
        assert json.loads(run("scenes", "--json", db=db).stdout) == []


def test_build_has_help() -> None:
    out = run("build", "--help").stdout
    assert "--config" in out and "--max-views" in out and "--no-cache" in out
