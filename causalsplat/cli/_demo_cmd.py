"""The ``demo`` command: the whole method end to end on a generated scene (DESIGN §13).

It writes a synthetic room (Gaussians, cameras, images, noisy SAM-like masks, GT and
queries), builds it (feature field, HDBSCAN entities, spatial edges) into SQLite, exports
Turtle, the PLY with the entity of each Gaussian beside it and a top-down figure of the
graph, and asks the offline reasoner one generated question of each reasoning level,
printing each program, its answer, whether the answer is the ground truth and its 3D IoU
on the Gaussians, then the stage timings.
"""

from __future__ import annotations

import shlex
import shutil
import sys
from pathlib import Path
from typing import Any

import click

from causalsplat.cli._app import cli, echo_json, json_option

LEVELS = ("spatial", "commonsense", "affordance", "counterfactual", "intrinsic")


@cli.command("demo")
@click.option(
    "-o", "--output", type=click.Path(file_okay=False, path_type=Path),
    default=Path("demo-out"), show_default=True,
    help="Folder for the scene, the database and the exports (replaced if it holds a demo).",
)  # fmt: skip
@click.option(
    "--size", type=click.Choice(["tiny", "small", "medium"]), default="small", show_default=True,
    help="Synthetic scene size.",
)  # fmt: skip
@click.option(
    "--seed", type=click.IntRange(min=0), default=0, show_default=True,
    help="Seed of the generated room (the same seed writes the same room).",
)  # fmt: skip
@click.option("--db", "db_url", default=None, help="Database URL (default: OUTPUT/demo.db).")
@json_option
def demo(output: Path, size: str, seed: int, db_url: str | None, as_json: bool) -> None:
    """Generate a room, build its scene graph from Gaussians and masks, export it, ask it."""
    import numpy as np

    from causalsplat.api import open_store
    from causalsplat.eval.reasoning import QueriesFile, evaluate_queries, read_queries
    from causalsplat.synth import synth_scene

    folder = output / "scene"
    if folder.exists():
        shutil.rmtree(folder)
    output.mkdir(parents=True, exist_ok=True)
    say = (lambda *_a: None) if as_json else click.echo
    say(f"1. writing a synthetic {size} room (seed {seed}) to {folder}")
    synth_scene(size, seed, folder)
    url = db_url or f"sqlite:///{output / 'demo.db'}"
    say(f"2. building its scene graph into {url}")
    with open_store(url) as store:
        scene = store.build(folder, if_exists="replace", cache_dir=output / "cache",
                            progress=not as_json and sys.stderr.isatty())  # fmt: skip
        report = scene.build_report
        assert report is not None
        graph = scene.graph
        turtle = output / f"{scene.id}.ttl"
        scene.export_rdf(turtle, format="turtle")
        ply = scene.export_ply(output / f"{scene.id}.ply")
        files = {
            "turtle": turtle,
            "ply": ply.ply,
            "labels": ply.labels_npy,
            "figure": scene.export_figure(output / f"{scene.id}_graph.png"),
        }
        queries = read_queries(folder / "queries.json")
        picked = [next(q for q in queries.queries if q.type == t) for t in LEVELS
                  if any(q.type == t for q in queries.queries)]  # fmt: skip
        gt = np.load(folder / "gt" / "gt_labels.npy")
        answers = [scene.ask(q.text) for q in picked]
        evaluated = evaluate_queries(
            scene._reasoning_context(),
            QueriesFile(queries.scene_id, tuple(picked), queries.source),
            scene._reasoner("offline", {}),
            gt_labels=gt,
        )
    rows = []
    for q, answer, outcome in zip(picked, answers, evaluated.per_query, strict=True):
        rows.append({
            "level": q.type, "question": q.text, "program": answer.program.to_text(),
            "answer": [{"id": i, "category": graph.get_entity(i).category}
                       for i in answer.entity_ids],
            "answer_gt_ids": list(outcome.predicted), "targets": list(q.targets),
            "correct": outcome.correct, "iou": outcome.iou,
        })  # fmt: skip
    doc: dict[str, Any] = {
        "db": url,
        "scene_id": graph.scene_id,
        "files": {k: str(v) for k, v in files.items()},
        "build": report.to_json(),
        "questions": rows,
    }
    if as_json:
        echo_json(doc)
        return
    _print(doc)


def _print(doc: dict[str, Any]) -> None:
    b = doc["build"]
    q = b["quality"]
    click.echo(
        f"   {b['entities']} entities, {b['relations']} relations from {b['gaussians']:,} "
        f"Gaussians, {b['views']} views, {b['masks']} masks; instance quality against the "
        f"generated GT: mean best IoU {q['mean_best_iou']:.3f}, AP50 {q['ap50']:.3f}, "
        f"PQ {q['pq']:.3f} ({q['split']} split, {q['merged']} merged objects)"
    )
    click.echo("3. exported: " + ", ".join(f"{k} {v}" for k, v in doc["files"].items()))
    click.echo("4. asking the offline reasoner one question of each level:")
    for row in doc["questions"]:
        mark = "correct" if row["correct"] else "WRONG"
        answer = ", ".join(f"{a['id']} {a['category']}" for a in row["answer"]) or "nothing"
        click.echo(f"\n   [{row['level']}] {row['question']}")
        for line in row["program"].splitlines():
            click.echo(f"      {line}")
        click.echo(
            f"   -> {answer}  (GT ids {row['answer_gt_ids']}, expected {row['targets']}: "
            f"{mark}, 3D IoU {row['iou']:.3f})"
        )
    click.echo("\n5. stage timings:")
    for stage in b["stages"]:
        tag = " (cached)" if stage["cached"] else ""
        click.echo(f"   {stage['name']:<10} {stage['seconds']:7.2f} s{tag}")
    click.echo(f"   peak memory {b['peak_rss_mib']:.0f} MiB")
    args = ["ask", "where can I sit?", "--scene", doc["scene_id"], "--db", doc["db"]]
    click.echo(f"\nquery it again: {_command()} {shlex.join(args)}")


def _command() -> str:
    """How to call this CLI from the current folder: ``causalsplat`` when the shell finds
    this very script on PATH, else its path (``.venv/bin/causalsplat`` after ``make demo``)."""
    script = Path(sys.executable).parent / "causalsplat"
    found = shutil.which("causalsplat")
    if found is not None and Path(found).resolve() == script.resolve():
        return "causalsplat"
    if not script.exists():
        return f"{shlex.quote(sys.executable)} -m causalsplat"
    try:
        relative = script.relative_to(Path.cwd())
    except ValueError:
        return shlex.quote(str(script))
    # a bare name would be looked up on PATH, not here
    return shlex.quote(str(relative) if len(relative.parts) > 1 else f"./{relative}")
