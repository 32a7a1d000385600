"""Store commands: ingest-objects, scenes, export, sparql, db."""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import click

from causalsplat.cli._app import SECONDS, cli, db_option, echo_json, entity_line, fail, json_option


def _open(db_url: str, *, create: bool = True) -> Any:
    """The store at ``db_url``; read-only commands pass ``create=False`` (no file made)."""
    from causalsplat.api import open_store

    return open_store(db_url, create=create)


@cli.command("ingest-objects")
@click.argument("file", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--scene", "scene_id", help="Scene id (default: the file's scene_id).")
@click.option(
    "--if-exists",
    type=click.Choice(["fail", "replace"]),
    default="fail",
    show_default=True,
    help="What to do when a scene with this id is already stored.",
)
@db_option
@json_option
def ingest_objects(
    file: Path, scene_id: str | None, if_exists: str, db_url: str, as_json: bool
) -> None:
    """Store a scene graph built from already segmented objects (objects JSON: docs/formats.md)."""
    from causalsplat.objects import objects_graph

    # a bad file is refused before the store is opened: no store file is created for it
    graph = objects_graph(file, scene_id=scene_id)
    with _open(db_url) as store:
        graph = store.save_scene(graph, if_exists=if_exists).graph
    counts: dict[str, int] = {}
    for r in graph.relations:
        counts[r.type.value] = counts.get(r.type.value, 0) + 1
    if as_json:
        echo_json(
            {
                "scene_id": graph.scene_id,
                "entities": len(graph.entities),
                "relations": len(graph.relations),
                "relations_by_type": counts,
            }
        )
        return
    click.echo(
        f"stored scene {graph.scene_id!r}: {len(graph.entities)} entities, "
        f"{len(graph.relations)} relations"
    )
    for e in graph.entities:
        cx, cy, cz = e.centroid
        click.echo(
            entity_line(e.id, e.category, e.external_id, after=f"({cx:.3f}, {cy:.3f}, {cz:.3f})")
        )


@cli.command("scenes")
@click.option(
    "--scenes",
    "--scene",
    "pattern",
    metavar="GLOB",
    help="Only the scenes whose id matches the glob (e.g. 'scene00*'); an error when none does.",
)
@click.option("--all-scenes", is_flag=True, help="Every stored scene (the default).")
@db_option
@json_option
def scenes(pattern: str | None, all_scenes: bool, db_url: str, as_json: bool) -> None:
    """List the stored scenes (all, or those whose id matches --scenes GLOB)."""
    if pattern is not None and all_scenes:
        fail("--scenes and --all-scenes are mutually exclusive: give one")
    with _open(db_url, create=False) as store:
        rows = store.scenes()
        if pattern is not None:
            chosen = set(store.scene_ids(pattern))
            rows = [s for s in rows if s.scene_id in chosen]
    if as_json:
        echo_json(
            [
                {
                    "scene_id": s.scene_id,
                    "name": s.name,
                    "source": s.source,
                    "units": s.units,
                    "up_axis": s.up_axis,
                    "entities": s.entity_count,
                    "relations": s.relation_count,
                    "created_at": s.created_at.isoformat(),
                    "config_hash": s.config_hash,
                }
                for s in rows
            ]
        )
        return
    if not rows:
        click.echo("no scenes stored")
        return
    click.echo(f"{'scene':<32} {'entities':>9} {'relations':>10}  source   created")
    for s in rows:
        created = s.created_at.strftime("%Y-%m-%d %H:%M")
        click.echo(
            f"{s.scene_id:<32} {s.entity_count:>9} {s.relation_count:>10}  {s.source:<8} {created}"
        )


@cli.command("export")
@click.option("--scene", "scene_ids", multiple=True, help="Scene id (repeatable; default: all).")
@click.option(
    "--format",
    "fmt",
    type=click.Choice(["turtle", "ntriples", "jsonld", "ply", "masks", "png"]),
    default="turtle",
    show_default=True,
    help="RDF (turtle, ntriples, jsonld; any scenes), or for one built scene: ply (the "
    "scene's 3DGS PLY unchanged, its labels in OUT.labels.npy and OUT.labels.json), masks "
    "(per-view PNG masks of --ask's answer), png (a top-down figure of the scene graph).",
)
@click.option(
    "-o", "--output", type=click.Path(path_type=Path), default=None,
    help="Output file (RDF: default stdout; ply, png: required), or folder (masks).",
)  # fmt: skip
@click.option("--no-evidence", is_flag=True, help="Leave out relation evidence nodes (RDF).")
@click.option(
    "--source", type=click.Path(file_okay=False, path_type=Path), default=None,
    help="The scene folder the scene was built from (default: the one recorded at build time).",
)  # fmt: skip
@click.option(
    "--per-entity", "per_entity", type=click.Path(file_okay=False, path_type=Path),
    default=None, help="ply: also write one PLY per entity into this folder.",
)  # fmt: skip
@click.option(
    "--embed-labels", is_flag=True,
    help="ply: append an int property causalsplat_entity to each vertex instead of writing "
    "the labels beside the PLY (SIBR-style viewers then refuse the file).",
)  # fmt: skip
@click.option(
    "--ask", "question", default=None, help="masks: the instruction whose answer to draw."
)
@click.option(
    "--overlay", is_flag=True,
    help="masks: also draw each mask over its view's image, into OUTPUT/overlay/.",
)  # fmt: skip
@db_option
@json_option
def export(
    scene_ids: tuple[str, ...],
    fmt: str,
    output: Path | None,
    no_evidence: bool,
    source: Path | None,
    per_entity: Path | None,
    embed_labels: bool,
    question: str | None,
    overlay: bool,
    db_url: str,
    as_json: bool,
) -> None:
    """Export stored scenes as RDF, or a built scene as its PLY and labels, answer masks or a
    figure."""
    if embed_labels and fmt != "ply":
        fail("--embed-labels is an option of --format ply")
    if overlay and fmt != "masks":
        fail("--overlay is an option of --format masks")
    if fmt in ("ply", "masks", "png"):
        options = _BuiltOptions(source, per_entity, embed_labels, question, overlay)
        _export_built(scene_ids, fmt, output, options, db_url, as_json)
        return
    with _open(db_url, create=False) as store:
        ids = list(scene_ids) or None
        if ids:
            for sid in ids:
                store.scene(sid)  # raises SceneNotFound before anything is written
        text = store.export_rdf(None, scene_ids=ids, format=fmt, evidence=not no_evidence)
    assert text is not None
    if output is None:
        sys.stdout.write(text)
        return
    from causalsplat.api import _write_atomic

    _write_atomic(output, text)
    if as_json:
        echo_json({"path": str(output), "format": fmt, "bytes": len(text.encode("utf-8"))})
    else:
        click.echo(f"wrote {output} ({fmt})")


@dataclass(frozen=True, slots=True)
class _BuiltOptions:
    source: Path | None
    per_entity: Path | None
    embed_labels: bool
    question: str | None
    overlay: bool


def _export_built(
    scene_ids: tuple[str, ...],
    fmt: str,
    output: Path | None,
    options: _BuiltOptions,
    db_url: str,
    as_json: bool,
) -> None:
    if len(scene_ids) != 1:
        fail(f"--format {fmt} exports one scene: pass exactly one --scene ID")
    if output is None:
        fail(f"--format {fmt} needs -o PATH")
    if fmt == "masks" and not options.question:
        fail("--format masks draws the answer to an instruction: pass --ask TEXT")
    with _open(db_url, create=False) as store:
        scene = store.scene(scene_ids[0])
        extra: dict[str, Any] = {}
        if fmt == "ply":
            paths = scene.export_ply(output, source=options.source, embed=options.embed_labels,
                                     per_entity_dir=options.per_entity).paths  # fmt: skip
        elif fmt == "masks":
            assert options.question is not None
            answer = scene.ask(options.question)
            extra = {"answer": list(answer.entity_ids), "explanation": answer.explanation}
            paths = scene.export_masks(answer.entity_ids, output, source=options.source,
                                       overlay=options.overlay)  # fmt: skip
        else:
            paths = [scene.export_figure(output)]
    if as_json:
        echo_json({"format": fmt, "paths": [str(p) for p in paths], **extra})
        return
    if "answer" in extra:
        click.echo(f"answer: entities {extra['answer']}")
    shown = paths if len(paths) <= 3 else paths[:1]
    for path in shown:
        click.echo(f"wrote {path}")
    if len(paths) > len(shown):
        rest = os.path.commonpath([p.parent for p in paths[len(shown) :]])
        click.echo(f"  and {len(paths) - len(shown)} more under {rest}")


_SPARQL_FORMATS = ["json", "xml", "csv", "tsv", "turtle", "ntriples", "nt", "jsonld", "rdfxml",
                   "nquads", "trig", "n3"]  # fmt: skip


def _parse_binding(text: str) -> tuple[str, Any]:
    name, sep, value = text.partition("=")
    if not sep or not name:
        fail(f"--bind expects NAME=VALUE, got {text!r}")
    for convert in (int, float):
        try:
            return name.lstrip("?$"), convert(value)
        except ValueError:
            pass
    return name.lstrip("?$"), value


def _query_text(path: Path) -> str:
    from causalsplat._json import utf8_text

    try:
        return utf8_text(path.read_bytes())
    except ValueError as exc:
        fail(f"{path}: not a SPARQL query: {exc}")


@cli.command("sparql")
@click.argument("query", required=False)
@click.option(
    "--file", "query_file", type=click.Path(dir_okay=False, path_type=Path),
    help="Read the query from this UTF-8 text file instead of QUERY.",
)  # fmt: skip
@click.option("--scene", "scene_ids", multiple=True, help="Scene id (repeatable; default: all).")
@click.option(
    "--scenes", "pattern", metavar="GLOB",
    help="The scenes whose id matches the glob (e.g. 'scene00*'), in one dataset.",
)  # fmt: skip
@click.option(
    "--all-scenes", is_flag=True,
    help="Every stored scene, in one dataset (the default): group rows per scene with"
    " ?scene bot:containsElement ?e.",
)  # fmt: skip
@click.option(
    "--bind", "binds", multiple=True, metavar="NAME=VALUE",
    help="Bind a variable to a literal (numbers are typed as numbers).",
)  # fmt: skip
@click.option(
    "--limit", type=click.IntRange(min=1), default=10_000, show_default=True,
    help="Most result rows; more are cut, with a note on stderr (page with LIMIT/OFFSET).",
)  # fmt: skip
@click.option(
    "--timeout", type=SECONDS, default=30.0, show_default=True,
    help="Seconds before the query is stopped (its worker killed, its memory freed).",
)  # fmt: skip
@click.option(
    "--backend", type=click.Choice(["auto", "oxigraph", "rdflib"]), default="auto",
    show_default=True,
    help="SPARQL engine: Oxigraph (fast), rdflib (pure Python), or auto (Oxigraph when"
    " installed).",
)  # fmt: skip
@click.option(
    "--format", "fmt", type=click.Choice(_SPARQL_FORMATS), default=None,
    help="W3C output: json, xml, csv, tsv (SELECT; json and xml for ASK); turtle, ntriples"
    " (nt), jsonld, rdfxml, nquads, trig, n3 (CONSTRUCT/DESCRIBE). Default: a plain table"
    " for SELECT, true/false for ASK, Turtle for graphs.",
)  # fmt: skip
@click.option(
    "--default-graph", "default_graphs", multiple=True, metavar="IRI",
    help="The default graph is the merge of these named graphs (repeatable; a scene's graph"
    " is its IRI, https://w3id.org/causalsplat/scene/ID), as the protocol's"
    " default-graph-uri; replaces the query's FROM (Oxigraph only).",
)  # fmt: skip
@click.option(
    "--named-graph", "named_graphs", multiple=True, metavar="IRI",
    help="GRAPH sees these named graphs only (repeatable), as the protocol's named-graph-uri.",
)  # fmt: skip
@db_option
@click.option(
    "--json", "as_json", is_flag=True,
    help="SPARQL 1.1 Query Results JSON (JSON-LD for CONSTRUCT/DESCRIBE).",
)  # fmt: skip
def sparql(
    query: str | None,
    query_file: Path | None,
    scene_ids: tuple[str, ...],
    pattern: str | None,
    all_scenes: bool,
    binds: tuple[str, ...],
    limit: int,
    timeout: float,
    backend: str,
    fmt: str | None,
    default_graphs: tuple[str, ...],
    named_graphs: tuple[str, ...],
    db_url: str,
    as_json: bool,
) -> None:
    """Run a read-only SPARQL query over the RDF view of stored scenes.

    QUERY is the query text ('-' reads stdin); or use --file. The prefixes csg:, bot:,
    geo:, rdf:, rdfs:, xsd: and owl: are predeclared. Updates, LOAD and SERVICE are
    refused. --json writes W3C SPARQL 1.1 Query Results JSON; CONSTRUCT and DESCRIBE
    write RDF (Turtle unless --format says).

    The query runs once over one dataset holding the chosen scenes (--scene, repeatable;
    --scenes GLOB; --all-scenes, the default): each scene is a named graph (its scene
    IRI) and the default graph their union, so GRAPH ?g tells the scenes apart and FROM
    picks some (nothing is loaded from elsewhere).
    """
    if (query is None) == (query_file is None):
        fail("give the query text or --file PATH (exactly one)")
    given = [n for n, on in (("--scene", scene_ids), ("--scenes", pattern), ("--all-scenes",
             all_scenes)) if on]  # fmt: skip
    if len(given) > 1:
        fail(f"{' and '.join(given)} are mutually exclusive: give one")
    fmt = {"nt": "ntriples"}.get(fmt or "", fmt)
    if as_json and fmt not in (None, "json", "jsonld"):
        fail(f"--json and --format {fmt} ask for two formats: give one")
    text = _query_text(query_file) if query_file else query
    if text == "-":
        text = sys.stdin.read()
    assert text is not None
    bindings: dict[str, Any] = {}
    for name, value in (_parse_binding(b) for b in binds):
        if name in bindings:
            fail(f"--bind {name} is given twice: bind each variable once")
        bindings[name] = value
    with _open(db_url, create=False) as store:
        ids = list(scene_ids) or None
        for sid in ids or ():
            store.scene(sid)
        if pattern is not None:
            ids = list(store.scene_ids(pattern))
        result = store.sparql(
            text, scene_ids=ids, bindings=bindings, limit=limit, timeout_s=timeout,
            backend=backend, default_graphs=default_graphs, named_graphs=named_graphs,
        )  # fmt: skip
    if as_json and fmt is None:
        fmt = "jsonld" if result.kind == "graph" else "json"
    if fmt is not None or result.kind == "graph":
        sys.stdout.write(result.serialize(fmt))
    elif result.kind == "ask":
        click.echo("true" if result.boolean else "false")
    else:
        click.echo("\t".join(result.columns))
        for row in result.rows:
            click.echo("\t".join("" if v is None else str(v) for v in row))
    if result.truncated:
        click.echo(f"(truncated at {limit} rows)", err=True)


@cli.group("db")
def db() -> None:
    """Manage the store: schema migrations (Alembic) and backups."""


@db.command("backup")
@click.argument("output", type=click.Path(dir_okay=False, path_type=Path))
@db_option
@json_option
def db_backup(output: Path, db_url: str, as_json: bool) -> None:
    """Copy a SQLite store into the new file OUTPUT, consistently even while it is in use
    (serve, a build): SQLite's online backup. The copy is a store on its own."""
    with _open(db_url, create=False) as store:
        path = store.backup(output)
        counts = len(store.scenes())
    if as_json:
        echo_json({"backup": str(path), "scenes": counts})
    else:
        click.echo(f"backed up {counts} scene(s) to {path}")


@db.command("upgrade")
@click.option("--revision", default="head", show_default=True, help="Target revision.")
@db_option
@json_option
def db_upgrade(revision: str, db_url: str, as_json: bool) -> None:
    """Migrate the store schema up to a revision (creates the schema in an empty database)."""
    from causalsplat.migrate import upgrade

    before, after = upgrade(db_url, revision)
    if as_json:
        echo_json({"from": before, "to": after})
    else:
        click.echo(f"schema revision: {before or '(empty)'} -> {after}")


@db.command("current")
@db_option
@json_option
def db_current(db_url: str, as_json: bool) -> None:
    """Print the store's schema revision."""
    from causalsplat.migrate import current

    revision = current(db_url)
    if as_json:
        echo_json({"revision": revision})
    else:
        click.echo(revision or "(empty)")
