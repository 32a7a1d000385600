"""SPARQL over the RDF view counts what SQL counts in the database, for random scenes."""

from __future__ import annotations

import sqlalchemy as sa
from hypothesis import HealthCheck, given, settings

from graph_store import STORED_RELATION_TYPES, SceneGraph, open_store
from graph_store import models as m
from graph_store.rdf import RdfView
from tests.strategies import scene_graphs

COUNT_ENTITIES = "SELECT (COUNT(?e) AS ?n) WHERE { ?e a csg:Entity }"
COUNT_BY_PREDICATE = "SELECT (COUNT(*) AS ?n) WHERE { ?a ?rel ?b }"
COUNT_BY_CATEGORY = "SELECT (COUNT(?e) AS ?n) WHERE { ?e csg:category ?cat }"


def _sql_count(conn: sa.Connection, table: sa.Table, *where: sa.ColumnElement[bool]) -> int:
    query = sa.select(sa.func.count()).select_from(table).where(*where)
    return int(conn.execute(query).scalar_one())


@given(graph=scene_graphs(max_entities=10, scene_id="s"))
@settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
def test_sparql_counts_equal_sql_counts(db_url: str, graph: SceneGraph) -> None:
    from rdflib import URIRef

    from graph_store.rdf import CSG

    with open_store(db_url) as store:
        store.save_scene(graph, if_exists="replace")
        stored = store.load_scene("s")
        views = [RdfView.from_graphs([stored], backend=b) for b in ("oxigraph", "rdflib")]
        with store.engine.connect() as conn:
            expected_entities = _sql_count(conn, m.entities, m.entities.c.scene_id == "s")
            by_type = {
                t: _sql_count(
                    conn, m.relations, m.relations.c.scene_id == "s", m.relations.c.type == t.value
                )
                for t in STORED_RELATION_TYPES
            }
            categories = {e.category for e in stored.entities}
            by_category = {
                c: _sql_count(
                    conn, m.entities, m.entities.c.scene_id == "s", m.entities.c.category == c
                )
                for c in categories
            }
        for view in views:
            assert view.query(COUNT_ENTITIES).rows == ((expected_entities,),)
            for rel, n in by_type.items():
                predicate = URIRef(str(CSG[rel.value]))
                result = view.query(COUNT_BY_PREDICATE, bindings={"rel": predicate})
                assert result.rows == ((n,),), rel
            for category, n in by_category.items():
                result = view.query(COUNT_BY_CATEGORY, bindings={"cat": category})
                assert result.rows == ((n,),), category
