"""The ``query`` command: run a structured program (DESIGN §6) on a stored scene."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import click

from causalsplat.cli._app import cli, db_option, echo_json, fail, json_option


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
    import sqlalchemy as sa

    from graph_store.models import entities

    if not ids:
        return []
    query = (
        sa.select(entities.c.id, entities.c.external_id, entities.c.category)
        .where(entities.c.scene_id == scene_id, entities.c.id.in_(ids))
        .order_by(entities.c.id)
    )
    with graph_store.engine.connect() as conn:
        rows = conn.execute(query).all()
    return [{"id": r.id, "external_id": r.external_id, "category": r.category} for r in rows]


@cli.command("query")
@click.argument("program", type=click.Path(dir_okay=False, allow_dash=True))
@click.option("--scene", "scene_id", required=True, help="Id of the stored scene to query.")
@click.option(
    "--executor",
    type=click.Choice(["networkx", "sql", "sparql"]),
    default="sql",
    show_default=True,
    help="networkx (in memory, the reference), sql (on the database) or sparql (Oxigraph).",
)
@click.option("--explain", is_flag=True, help="Print the program with each step's result.")
@db_option
@json_option
def query(
    program: str, scene_id: str, executor: str, explain: bool, db_url: str, as_json: bool
) -> None:
    """Run a structured graph query (PROGRAM: a JSON file, or the text form; - for stdin).

    The answer is a set of entities, a count or a yes/no. --explain shows the text form of
    the program with the size of every step's result (and why each entity falls, for
    counterfactual programs).
    """
    from causalsplat.api import open_store
    from queries import run_program

    parsed = _read_program(program)
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
    if isinstance(answer, bool):
        click.echo("yes" if answer else "no")
    elif isinstance(answer, int):
        click.echo(str(answer))
    else:
        click.echo(f"{len(ents)} entit{'y' if len(ents) == 1 else 'ies'}")
        for e in ents:
            click.echo(f"  {e['id']:>6}  {e['category']:<24} ext={e['external_id']}")
