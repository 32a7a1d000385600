"""The Python API of DESIGN §10 over a real store."""

from __future__ import annotations

from pathlib import Path

import pytest

from causalsplat import open_store
from graph_store import Entity, Relation, SceneGraph, SceneMeta, SceneNotFound
from tests.graph_store.test_repository import small_scene

EVIDENCE_QUERY = """
SELECT ?gap WHERE {
  ?r a csg:RelationAssertion ; csg:predicate csg:supported_by ; csg:hasEvidence ?ev .
  ?ev csg:name "gap" ; csg:value ?gap .
}"""


def test_scene_handles_lookups_sparql_and_export(tmp_path: Path) -> None:
    with open_store(f"sqlite:///{tmp_path / 's.db'}") as store:
        store.save_scene(small_scene())
        scene = store.scene("kitchen")
        assert scene.get_entity(1).category == "cup"
        assert scene.find_entity(9) is None and scene.has_entity(0)
        rows = scene.sparql("SELECT ?a ?b WHERE { ?a csg:supported_by ?b }").rows
        assert [tuple(v.rsplit("/", 1)[1] for v in row) for row in rows] == [("1", "0")]
        # The view holds the export's triples, relation evidence included.
        assert scene.sparql(EVIDENCE_QUERY).rows == ((0.0,),)
        assert scene.sparql(EVIDENCE_QUERY, evidence=False).rows == ()
        ttl = tmp_path / "kitchen.ttl"
        scene.export_rdf(ttl)
        assert "csg:supported_by" in ttl.read_text()
        with pytest.raises(SceneNotFound, match="no scene 'nowhere'"):
            store.scene("nowhere")


def test_store_sparql_sees_replaced_scenes(tmp_path: Path) -> None:
    query = "SELECT (COUNT(?e) AS ?n) WHERE { ?e a csg:Entity }"
    with open_store(f"sqlite:///{tmp_path / 's.db'}") as store:
        store.save_scene(small_scene())
        assert store.sparql(query).rows == ((2,),)
        assert store.sparql(query).rows == ((2,),)  # served by the cached view
        bigger = SceneGraph(
            SceneMeta("kitchen"),
            (
                *small_scene().entities,
                Entity(2, "plate", (3, 0, 0), (2.9, -0.1, 0), (3.1, 0.1, 0.02)),
            ),
            (Relation(2, 0, "near"),),
        )
        store.save_scene(bigger, if_exists="replace")
        assert store.sparql(query).rows == ((3,),)
        store.save_scene(small_scene("second"))
        assert store.sparql(query).rows == ((5,),)
        assert store.sparql(query, scene_ids=["second"]).rows == ((2,),)
        with pytest.raises(SceneNotFound):
            store.sparql(query, scene_ids=["missing"])
