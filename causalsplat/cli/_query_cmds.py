"""The ``query`` command: run a structured program (DESIGN §6) on a stored scene."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import click

from causalsplat.cli._app import cli, db_option, echo_json, entity_line, fail, json_option
from causalsplat.cli._scene_select import scene_choice, scene_options


def _read_program(path: str) -> Any:
    """A program from a JSON file or a text-form file (``-``: standard input)."""
    from queries import GraphQuery

    try:
        text = sys.stdin.read() if path == "-" else Path(path).read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        fail(f"{path}: a program is JSON or the text form, not binary data ({exc.reason})")
    if text.lstrip().startswith("{"):
        return GraphQuery.parse(text)
    return GraphQuery.from_text(text)


def _entities(graph_store: Any, scene_id: str, ids: tuple[int, ...]) -> list[dict[str, Any]]:
    """``id``, ``external_id`` and ``category`` of the answer's entities, in id order."""
    return _entities_of(graph_store, {scene_id: ids}).get(scene_id, [])


def _entities_of(
    graph_store: Any, answers: dict[str, tuple[int, ...]]
) -> dict[str, list[dict[str, Any]]]:
    """The answer entities of several scenes (scene id -> ids), one query per 500 scenes."""
    import sqlalchemy as sa

    from graph_store.models import entities as e

    wanted = {sid: set(ids) for sid, ids in answers.items() if ids}
    out: dict[str, list[dict[str, Any]]] = {sid: [] for sid in answers}
    chunks = [sorted(wanted)[i : i + 500] for i in range(0, len(wanted), 500)]
    with graph_store.engine.connect() as conn:
        for chunk in chunks:
            query = (
                sa.select(e.c.scene_id, e.c.id, e.c.external_id, e.c.category)
                .where(e.c.scene_id.in_(chunk))
                .order_by(e.c.scene_id, e.c.id)
            )
            for r in conn.execute(query):
                if r.id in wanted[r.scene_id]:
                    doc = {"id": r.id, "external_id": r.external_id, "category": r.category}
                    out[r.scene_id].append(doc)
    return out


def _describe_answer(answer: Any, ents: list[dict[str, Any]]) -> list[str]:
    """The human lines of one answer (yes/no, a count, or the entities)."""
    if isinstance(answer, bool):
        return ["yes" if answer else "no"]
    if isinstance(answer, int):
        return [str(answer)]
    lines = [f"{len(ents)} entit{'y' if len(ents) == 1 else 'ies'}"]
    lines += [entity_line(e["id"], e["category"], e["external_id"], 6) for e in ents]
    return lines


@cli.command("query")
@click.argument("program", type=click.Path(dir_okay=False, allow_dash=True))
@scene_options
@click.option(
    "--executor",
    type=click.Choice(["networkx", "memory", "sql", "sparql"]),
    default="sql",
    show_default=True,
    help="networkx (the reference, on networkx graphs), memory (the same on plain dicts, "
    "without importing networkx), sql (on the database) or sparql (Oxigraph).",
)
@click.option("--explain", is_flag=True, help="Print the program with each step's result.")
@db_option
@json_option
def query(
    program: str,
    scene_id: str | None,
    scenes_glob: str | None,
    all_scenes: bool,
    executor: str,
    explain: bool,
    db_url: str,
    as_json: bool,
) -> None:
    """Run a structured graph query (PROGRAM: a JSON file, or the text form; - for stdin).

    The answer is a set of entities, a count or a yes/no. --explain shows the text form of
    the program with the size of every step's result (and why each entity falls, for
    counterfactual programs).

    With --all-scenes or --scenes GLOB the program runs on every selected scene (the sql
    executor answers them all with one statement, sparql with one query per step); the
    output lists the scenes with a non-empty answer and a count line, --json every scene's
    result.
    """
    from causalsplat.api import open_store
    from queries import run_program

    choice = scene_choice(scene_id, scenes_glob, all_scenes)
    parsed = _read_program(program)
    if choice.many:
        _query_many(parsed, choice.selection, executor, explain, db_url, as_json)
        return
    assert scene_id is not None
    with open_store(db_url, create=False) as store:
        result = run_program(store.graph_store, scene_id, parsed, executor=executor)
        answer = result.answer
        ents = _entities(store.graph_store, scene_id, answer) if isinstance(answer, tuple) else []
    if as_json:
        document = result.to_dict()
        document["entities"] = ents
        if explain:
            document["explain"] = result.explain()
        echo_json(document)
        return
    if explain:
        click.echo(result.explain())
    for line in _describe_answer(answer, ents):
        click.echo(line)


def _query_many(
    program: Any, selection: str | None, executor: str, explain: bool, db_url: str, as_json: bool
) -> None:
    """``query`` over many scenes: every result with --json, else the answered ones."""
    from causalsplat.api import open_store

    with open_store(db_url, create=False) as store:
        results = store.query_all(program, scenes=selection, executor=executor)
        shown = results.results if as_json else results.answered()
        sets = {r.scene_id: r.answer for r in shown if isinstance(r.answer, tuple)}
        ents = _entities_of(store.graph_store, sets)
    if as_json:
        document = results.to_dict()
        for doc in document["results"]:
            doc["entities"] = ents.get(doc["scene_id"], [])
            if explain:
                doc["explain"] = results[doc["scene_id"]].explain()
        echo_json(document)
        return
    for r in shown:
        lines = _describe_answer(r.answer, ents.get(r.scene_id, []))
        click.echo(f"{r.scene_id}: {lines[0]}")
        for line in lines[1:]:
            click.echo(line)
        if explain:
            click.echo(r.explain())
    click.echo(f"{len(shown)} of {len(results)} scenes answered")
