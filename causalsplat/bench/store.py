"""Store benchmark: ingest, load, RDF export, and a 2-hop query in SPARQL and SQL.

For graphs of 1k, 10k and 100k entities (10 relations per entity), all in one process:

- ``save_scene`` into a fresh SQLite file (Core executemany in one transaction) against
  the baseline of the same rows written with the ORM's ``add_all`` (1k and 10k only);
- ``load_scene`` back, checked equal to what was saved;
- Turtle and N-Triples export (our streaming writer) with the triple count, with and
  without relation evidence (at 100k only without: with it the document passes 10M
  triples), against rdflib's own Turtle serializer (1k only: it takes minutes at 10k);
- a 2-hop query ("things resting on something that rests on a table") as SPARQL on the
  view the API builds for relation queries (no evidence nodes), on
  Oxigraph, the same on rdflib's engine (baseline, 1k only), and the equivalent SQL join on
  SQLite; the three answers are compared (the "error" column: rows that differ).
"""

from __future__ import annotations

import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import sqlalchemy as sa

from causalsplat.bench import BenchReport
from graph_store import (
    STORED_RELATION_TYPES,
    Attribute,
    Entity,
    Relation,
    SceneGraph,
    SceneMeta,
    open_store,
)
from graph_store import models as m
from graph_store.repository import _scene_rows

NAME = "store"
RELATIONS_PER_ENTITY = 10
CATEGORIES = ("table", "cup", "book", "chair", "shelf", "lamp", "plate", "bowl", "sink", "bed")

SPARQL_2HOP = """
SELECT ?a ?c WHERE {
  ?c csg:category ?anchor .
  ?b csg:supported_by ?c .
  ?a csg:supported_by ?b .
}"""


def synthetic_graph(n_entities: int, *, seed: int = 0) -> SceneGraph:
    """A random scene with ``10 * n`` relations of every stored type, with evidence."""
    rng = np.random.default_rng(seed)
    centers = rng.uniform(-50, 50, size=(n_entities, 3))
    half = rng.uniform(0.05, 1.0, size=(n_entities, 3))
    entities = tuple(
        Entity(
            id=i,
            category=CATEGORIES[i % len(CATEGORIES)],
            centroid=tuple(centers[i]),
            bbox_min=tuple(centers[i] - half[i]),
            bbox_max=tuple(centers[i] + half[i]),
            external_id=str(i),
            point_count=int(rng.integers(10, 5000)),
            attributes=(Attribute("color", ("red", "blue", "white")[i % 3]),),
        )
        for i in range(n_entities)
    )
    n_rel = RELATIONS_PER_ENTITY * n_entities
    src = rng.integers(0, n_entities, size=2 * n_rel)
    dst = rng.integers(0, n_entities, size=2 * n_rel)
    typ = rng.integers(0, len(STORED_RELATION_TYPES), size=2 * n_rel)
    seen: set[tuple[int, int, int]] = set()
    relations = []
    for a, b, t in zip(src.tolist(), dst.tolist(), typ.tolist(), strict=True):
        if a != b and (a, b, t) not in seen:
            seen.add((a, b, t))
            relations.append(
                Relation(a, b, STORED_RELATION_TYPES[t], {"distance": abs(a - b) / n_entities})
            )
            if len(relations) == n_rel:
                break
    return SceneGraph(SceneMeta(f"bench-{n_entities}", source="build"), entities, tuple(relations))


def _time(fn: Callable[[], Any], repeat: int = 1) -> tuple[float, Any]:
    """Median wall time in seconds over ``repeat`` runs, and the last result."""
    times, result = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


class _Row:
    """A row object for the ORM baseline, built as declarative's default constructor does."""

    def __init__(self, **columns: Any) -> None:
        for key, value in columns.items():
            setattr(self, key, value)


class _SceneRow(_Row):
    pass


class _EntityRow(_Row):
    pass


class _EntityAttributeRow(_Row):
    pass


class _RelationRow(_Row):
    pass


_ORM_CLASSES = {
    _SceneRow: m.scenes,
    _EntityRow: m.entities,
    _EntityAttributeRow: m.entity_attributes,
    _RelationRow: m.relations,
}


def _orm_add_all(url: str, graph: SceneGraph) -> None:
    """Baseline: the same rows through the ORM unit of work (``Session.add_all``), with
    classes mapped imperatively onto the store's Core tables for this benchmark only."""
    from sqlalchemy.orm import Session, class_mapper, registry
    from sqlalchemy.orm.exc import UnmappedClassError

    for cls, table in _ORM_CLASSES.items():
        try:
            class_mapper(cls)
        except UnmappedClassError:
            registry().map_imperatively(cls, table)
    rows = _scene_rows(graph)
    engine = sa.create_engine(url)
    m.metadata.create_all(engine)
    with Session(engine) as session:
        session.add(_SceneRow(**rows.scene))
        session.add_all(_EntityRow(**r) for r in rows.entities)
        session.add_all(_EntityAttributeRow(**r) for r in rows.attributes)
        session.add_all(_RelationRow(**r) for r in rows.relations)
        session.commit()
    engine.dispose()


def _sql_2hop(store: Any, scene_id: str, anchor: str) -> set[tuple[int, int]]:
    e, r1, r2 = m.entities, m.relations.alias("r1"), m.relations.alias("r2")
    query = (
        sa.select(r1.c.src, r2.c.dst)
        .join(r2, sa.and_(r2.c.scene_id == r1.c.scene_id, r2.c.src == r1.c.dst))
        .join(e, sa.and_(e.c.scene_id == r2.c.scene_id, e.c.id == r2.c.dst))
        .where(
            r1.c.scene_id == scene_id,
            r1.c.type == "supported_by",
            r2.c.type == "supported_by",
            e.c.category == anchor,
        )
    )
    with store.engine.connect() as conn:
        return {(a, c) for a, c in conn.execute(query)}


def _sparql_ids(result: Any, scene_iri: str) -> set[tuple[int, int]]:
    prefix = f"{scene_iri}/entity/"
    return {(int(a[len(prefix) :]), int(c[len(prefix) :])) for a, c in result.rows}


def _measure(
    n: int,
    workdir: Path,
    *,
    orm_baseline: bool,
    rdflib_baseline: bool,
    full_rdf: bool,
    repeat: int,
) -> dict[str, Any]:
    from graph_store.rdf import RdfView, scene_iri, serialize_scenes, to_rdflib_graph

    graph = synthetic_graph(n, seed=n)
    row: dict[str, Any] = {"entities": n, "relations": len(graph.relations)}
    url = f"sqlite:///{workdir / f'core-{n}.db'}"
    with open_store(url) as store:
        row["ingest_s"], _ = _time(lambda: store.save_scene(graph))
        row["load_s"], loaded = _time(lambda: store.load_scene(graph.scene_id))
        row["round_trip_equal"] = loaded == graph
        if orm_baseline:
            orm_url = f"sqlite:///{workdir / f'orm-{n}.db'}"
            row["orm_add_all_s"], _ = _time(lambda: _orm_add_all(orm_url, graph))

        if full_rdf:
            row["turtle_s"], ttl = _time(lambda: serialize_scenes(graph, "turtle"))
            row["ntriples_s"], nt = _time(lambda: serialize_scenes(graph, "ntriples"))
            row["triples"] = nt.count("\n")
            row["turtle_mb"] = len(ttl.encode()) / 1e6
            del ttl, nt
        row["turtle_no_evidence_s"], light = _time(
            lambda: serialize_scenes(graph, "turtle", evidence=False)
        )
        row["triples_no_evidence"] = sum(
            1 for line in serialize_scenes(graph, "ntriples", evidence=False).splitlines() if line
        )
        del light
        if rdflib_baseline:
            rdf = to_rdflib_graph(graph)
            row["rdflib_turtle_s"], _ = _time(lambda: rdf.serialize(format="turtle"))

        # The view the API builds for relation queries (evidence only when a query asks).
        row["oxigraph_build_s"], view = _time(
            lambda: RdfView.from_graphs([graph], backend="oxigraph", evidence=False)
        )
        bindings = {"anchor": "table"}
        row["sparql_2hop_s"], result = _time(
            lambda: view.query(SPARQL_2HOP, bindings=bindings, limit=10**7), repeat
        )
        sparql_rows = _sparql_ids(result, scene_iri(graph.scene_id))
        row["sql_2hop_s"], sql_rows = _time(
            lambda: _sql_2hop(store, graph.scene_id, "table"), repeat
        )
        row["answer_rows"] = len(sql_rows)
        row["rows_differing_sparql_sql"] = len(sparql_rows ^ sql_rows)
        if rdflib_baseline:
            rdflib_view = RdfView.from_graphs([graph], backend="rdflib", evidence=False)
            row["rdflib_2hop_s"], rdflib_result = _time(
                lambda: rdflib_view.query(SPARQL_2HOP, bindings=bindings, limit=10**7)
            )
            row["rows_differing_rdflib_sql"] = len(
                _sparql_ids(rdflib_result, scene_iri(graph.scene_id)) ^ sql_rows
            )
    return row


def _ms(seconds: float | None) -> str:
    """Milliseconds, or a dash where the benchmark did not measure it."""
    return "–" if seconds is None else f"{seconds * 1e3:,.1f}"


def _ratio(a: float | None, b: float | None) -> str:
    return "–" if a is None or b is None or b == 0 else f"{a / b:,.1f}x"


def _markdown(rows: list[dict[str, Any]]) -> str:
    lines = [
        "Times in ms (median); ratios are baseline time / our time, from the same run.",
        "",
        "| entities | relations | ingest | ORM add_all | ratio | load | round trip |",
        "|---:|---:|---:|---:|---:|---:|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['entities']:,} | {r['relations']:,} | {_ms(r['ingest_s'])} "
            f"| {_ms(r.get('orm_add_all_s'))} | {_ratio(r.get('orm_add_all_s'), r['ingest_s'])} "
            f"| {_ms(r['load_s'])} | {'equal' if r['round_trip_equal'] else 'DIFFERS'} |"
        )
    lines += [
        "",
        "| entities | triples | Turtle | N-Triples | rdflib Turtle | ratio | Turtle MB "
        "| triples, no evidence | Turtle, no evidence |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        triples = f"{r['triples']:,}" if "triples" in r else "–"
        size = f"{r['turtle_mb']:.1f}" if "turtle_mb" in r else "–"
        lines.append(
            f"| {r['entities']:,} | {triples} | {_ms(r.get('turtle_s'))} "
            f"| {_ms(r.get('ntriples_s'))} | {_ms(r.get('rdflib_turtle_s'))} "
            f"| {_ratio(r.get('rdflib_turtle_s'), r.get('turtle_s'))} | {size} "
            f"| {r['triples_no_evidence']:,} | {_ms(r['turtle_no_evidence_s'])} |"
        )
    lines += [
        "",
        "2-hop query (`?a supported_by ?b supported_by ?c`, `?c` a table): SPARQL on Oxigraph,"
        " the rdflib engine as baseline, and the SQL join on SQLite. 'Rows differing' is the"
        " symmetric difference of the answers against SQL (the error column: must be 0).",
        "",
        "| entities | answer rows | Oxigraph load | SPARQL (Oxigraph) | SQL (SQLite) "
        "| SPARQL (rdflib) | rdflib / Oxigraph | rows differing |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        differing = r["rows_differing_sparql_sql"] + r.get("rows_differing_rdflib_sql", 0)
        lines.append(
            f"| {r['entities']:,} | {r['answer_rows']:,} | {_ms(r['oxigraph_build_s'])} "
            f"| {_ms(r['sparql_2hop_s'])} | {_ms(r['sql_2hop_s'])} | {_ms(r.get('rdflib_2hop_s'))} "
            f"| {_ratio(r.get('rdflib_2hop_s'), r['sparql_2hop_s'])} | {differing} |"
        )
    return "\n".join(lines)


def _growth(first: dict[str, Any], last: dict[str, Any]) -> str:
    def grow(key: str) -> str:
        return f"{last[key] / first[key]:,.0f}x"

    size = last["entities"] / first["entities"]
    return (
        f"\n\nGrowth from {first['entities']:,} to {last['entities']:,} entities ({size:,.0f}x):"
        f" ingest {grow('ingest_s')}, load {grow('load_s')}, Turtle export without evidence"
        f" {grow('turtle_no_evidence_s')}, SQL 2-hop {grow('sql_2hop_s')}, SPARQL 2-hop"
        f" {grow('sparql_2hop_s')}."
    )


def run(*, quick: bool = False) -> BenchReport:
    sizes = (1_000, 10_000) if quick else (1_000, 10_000, 100_000)
    rows = []
    with tempfile.TemporaryDirectory(prefix="causalsplat-bench-store-") as tmp:
        for n in sizes:
            rows.append(
                _measure(
                    n,
                    Path(tmp),
                    orm_baseline=n <= 10_000,
                    rdflib_baseline=n <= 1_000,
                    full_rdf=n <= 10_000,
                    repeat=5,
                )
            )
    note = _growth(rows[0], rows[-1]) if len(rows) >= 2 else ""
    return BenchReport(
        NAME, "Store: ingest, export, 2-hop queries", _markdown(rows) + note, {"rows": rows}
    )
