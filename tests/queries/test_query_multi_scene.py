"""Questions across scenes: ``run_program_all`` gives every scene exactly the result of a
run on that scene alone, on the three executors (SQL on SQLite and PostgreSQL, SPARQL on
Oxigraph and, for the scenes a glob selects, rdflib), for random
programs over random scenes whose ids need escaping; scene selection by glob and by list;
empty stores and bad selections."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from graph_store.errors import SceneNotFound
from graph_store.repository import GraphStore, open_store
from graph_store.types import SceneGraph
from queries import (
    GraphQuery,
    MultiSceneResult,
    QueryExecutionError,
    QueryValidationError,
    run_program_all,
    select_scene_ids,
)
from queries.networkx_executor import NetworkxExecutor
from tests.queries.query_strategies import programs, scenes

#: Scene ids that a literal list must escape (quotes, a backslash, a slash, non-ASCII).
SCENE_IDS = ("a plain", "b x' OR '1'='1", 'c scène/1 "q" \\')
_SETTINGS = {
    "deadline": None,
    "suppress_health_check": [HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
}


@pytest.fixture(params=["sqlite", pytest.param("postgres", marks=pytest.mark.postgres)])
def store(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[GraphStore]:
    if request.param == "sqlite":
        url = f"sqlite:///{tmp_path / 'many.db'}"
    else:
        url = str(request.getfixturevalue("postgres_url"))
    s = open_store(url)
    try:
        yield s
    finally:
        s.close()


def _fill(store: GraphStore, graphs: list[SceneGraph]) -> None:
    for summary in store.list_scenes():
        store.delete_scene(summary.scene_id)
    for g in graphs:
        store.save_scene(g)


def _scene_sets(draw: st.DrawFn) -> list[SceneGraph]:
    return [draw(scenes(scene_id=sid)) for sid in SCENE_IDS]


def _check(store: GraphStore, graphs: list[SceneGraph], batch: list[GraphQuery]) -> None:
    reference = {g.scene_id: NetworkxExecutor(g) for g in graphs}
    for program in batch:
        for executor in ("sql", "sparql", "networkx"):
            got = run_program_all(store, program, executor=executor)
            assert got.scene_ids == tuple(sorted(SCENE_IDS))
            for sid, result in got.items():
                expected = reference[sid].run(program)
                assert result == expected, (
                    f"{executor} on {sid!r} disagrees with the per-scene run of\n"
                    f"{program.to_text()}\n{result.steps} vs {expected.steps}\n"
                    f"{result.support_paths} vs {expected.support_paths}"
                )
        sub = run_program_all(store, program, scenes=list(SCENE_IDS[:2]), executor="sql")
        assert sub.scene_ids == SCENE_IDS[:2]
        assert all(sub[sid] == reference[sid].run(program) for sid in SCENE_IDS[:2])
        sub = run_program_all(
            store, program, scenes="[ac]*", executor="sparql", sparql_backend="rdflib"
        )
        assert sub.scene_ids == (SCENE_IDS[0], SCENE_IDS[2])
        assert all(r == reference[r.scene_id].run(program) for r in sub.values())


def test_every_scene_matches_its_own_run(store: GraphStore) -> None:
    @settings(max_examples=12, **_SETTINGS)  # type: ignore[arg-type]
    @given(data=st.data(), batch=st.lists(programs(), min_size=3, max_size=3))
    def check(data: st.DataObject, batch: list[GraphQuery]) -> None:
        graphs = [data.draw(scenes(scene_id=sid)) for sid in SCENE_IDS]
        _fill(store, graphs)
        _check(store, graphs, batch)

    check()


COUNTERFACTUAL = {
    "query_type": "counterfactual",
    "steps": [
        {"op": "scene"},
        {"op": "filter_category", "inputs": [0], "value": "table"},
        {"op": "fall_if_removed", "inputs": [1]},
        {"op": "count", "inputs": [2]},
    ],
    "answer_step": 2,
}


def _support_scene(scene_id: str, with_cup: bool) -> SceneGraph:
    from graph_store.types import Entity, Relation, RelationType, SceneMeta

    def box(i: int, cat: str, z: float) -> Entity:
        return Entity(
            id=i,
            category=cat,
            centroid=(0.0, 0.0, z),
            bbox_min=(-0.5, -0.5, z - 0.5),
            bbox_max=(0.5, 0.5, z + 0.5),
        )

    ents = [box(1, "floor", 0.0), box(2, "table", 1.0)]
    rels = [Relation(2, 1, RelationType.SUPPORTED_BY)]
    if with_cup:
        ents += [box(3, "cup", 2.0), box(4, "spoon", 3.0)]
        rels += [Relation(3, 2, RelationType.SUPPORTED_BY), Relation(3, 4, RelationType.SUPPORTS)]
    return SceneGraph(SceneMeta(scene_id), tuple(ents), tuple(rels))


def test_counterfactual_paths_are_per_scene(store: GraphStore) -> None:
    graphs = [_support_scene("s1", True), _support_scene("s2", False), _support_scene("s3", True)]
    _fill(store, graphs)
    got = run_program_all(store, COUNTERFACTUAL)
    assert [r.answer for r in got.values()] == [(3, 4), (), (3, 4)]
    assert [p.path for p in got["s1"].support_paths] == [(3, 2), (4, 3, 2)]
    assert got["s2"].support_paths == ()
    assert [r.scene_id for r in got.answered()] == ["s1", "s3"]
    for g in graphs:
        assert got[g.scene_id] == NetworkxExecutor(g).run(COUNTERFACTUAL)


def _every_path(
    store: GraphStore, program: dict[str, Any], sql_scenes: list[str], sparql_scenes: list[str]
) -> list[MultiSceneResult]:
    """``program`` over all scenes on SQL, SPARQL (Oxigraph and rdflib) and networkx, and
    over the given subsets on SQL and SPARQL."""
    runs = [run_program_all(store, program, executor=e) for e in ("sql", "sparql", "networkx")]
    return [
        *runs,
        run_program_all(store, program, executor="sparql", sparql_backend="rdflib"),
        run_program_all(store, program, scenes=sql_scenes, executor="sql"),
        run_program_all(store, program, scenes=sparql_scenes, executor="sparql"),
    ]


COALESCE = {
    "query_type": "spatial",
    "steps": [
        {"op": "scene"},
        {"op": "filter_category", "inputs": [0], "value": "cup"},
        {"op": "filter_category", "inputs": [0], "value": "spoon"},
        {"op": "filter_category", "inputs": [0], "value": "table"},
        {"op": "coalesce", "inputs": [1, 3]},
        {"op": "coalesce", "inputs": [1, 2]},
        {"op": "coalesce", "inputs": [2, 1, 3]},
        {"op": "count", "inputs": [4]},
    ],
    "answer_step": 4,
}


def test_coalesce_chooses_per_scene(store: GraphStore) -> None:
    """The cup and the spoon are in s1 and s3, not in s2: each scene takes its own first
    non-empty input, on every executor, with and without a scene filter."""
    graphs = [_support_scene("s1", True), _support_scene("s2", False), _support_scene("s3", True)]
    _fill(store, graphs)
    runs = _every_path(store, COALESCE, ["s1", "s2"], ["s2", "s3"])
    reference = {g.scene_id: NetworkxExecutor(g).run(COALESCE) for g in graphs}
    # steps 4 to 7: coalesce(cup, table), coalesce(cup, spoon), coalesce(spoon, cup, table)
    chosen = {"s1": ((3,), (3,), (4,), 1), "s2": ((2,), (), (2,), 1)}
    chosen["s3"] = chosen["s1"]
    for got in runs:
        for sid, result in got.items():
            assert result.steps[4:] == chosen[sid], (got.executor, sid)
            assert result == reference[sid]


def _cups(scene_id: str, xs: tuple[float, ...]) -> SceneGraph:
    """A table at the origin and cups ``10, 11, ...`` at ``x = xs[0], xs[1], ...``."""
    from graph_store.types import Entity, SceneMeta

    def box(i: int, cat: str, x: float, z: float) -> Entity:
        return Entity(i, cat, (x, 0.0, z), (x - 0.2, -0.2, z - 0.2), (x + 0.2, 0.2, z + 0.2))

    ents = [box(1, "table", 0.0, 0.4), *(box(10 + n, "cup", x, 0.8) for n, x in enumerate(xs))]
    return SceneGraph(SceneMeta(scene_id), tuple(ents))


MIDDLE = {
    "query_type": "spatial",
    "steps": [
        {"op": "scene"},
        {"op": "filter_category", "inputs": [0], "value": "cup"},
        {"op": "filter_category", "inputs": [0], "value": "table"},
        {"op": "middle", "inputs": [1], "metric": "x"},
        {"op": "middle", "inputs": [1, 2], "metric": "distance"},
        # looking along +y from below the table: right is +x
        {"op": "middle", "inputs": [1], "metric": "rightward",
         "viewpoint": {"eye": [0.0, -5.0, 1.0], "target": [0.0, 0.0, 1.0]}},
        {"op": "count", "inputs": [3]},
    ],
    "answer_step": 3,
}  # fmt: skip


def test_middle_chooses_per_scene(store: GraphStore) -> None:
    """Five cups in s1, two in s2, none in s3, three level with each other in s4: each
    scene keeps the middle of its own cups, on every executor, with and without a scene
    filter."""
    graphs = [
        _cups("s1", (3.0, 1.0, 2.0, 5.0, 4.0)),  # by x: 11, 12, 10, 14, 13
        _cups("s2", (2.0, 1.0)),  # by x: 11, 10
        _cups("s3", ()),
        _cups("s4", (2.0, 2.0, 2.0)),  # a tie: by id
    ]
    _fill(store, graphs)
    runs = _every_path(store, MIDDLE, ["s1", "s2", "s4"], ["s2", "s3"])
    reference = {g.scene_id: NetworkxExecutor(g).run(MIDDLE) for g in graphs}
    # steps 3 to 6: by x, by distance to the table, by rightward, the count of the first
    chosen = {
        "s1": ((10,), (10,), (10,), 1),
        "s2": ((10, 11), (10, 11), (10, 11), 2),
        "s3": ((), (), (), 0),
        "s4": ((11,), (11,), (11,), 1),
    }
    for got in runs:
        assert got.scene_ids
        for sid, result in got.items():
            assert result.steps[3:] == chosen[sid], (got.executor, sid)
            assert result == reference[sid]


def test_selection_by_glob_list_and_errors(store: GraphStore) -> None:
    _fill(store, [_support_scene(s, True) for s in ("scene0001_00", "scene0002_00", "other")])
    program = GraphQuery.parse(COUNTERFACTUAL)
    assert select_scene_ids(store, "scene000*") == ("scene0001_00", "scene0002_00")
    assert select_scene_ids(store, ["other", "scene0002_00", "other"]) == (
        "other",
        "scene0002_00",
    )
    assert select_scene_ids(store, "other") == ("other",)
    with pytest.raises(SceneNotFound, match=r"no stored scene matches 'x\*' \(3 stored\)"):
        run_program_all(store, program, scenes="x*")
    with pytest.raises(SceneNotFound, match="no scene 'missing'"):
        run_program_all(store, program, scenes=["other", "missing"])
    with pytest.raises(QueryExecutionError, match="unknown executor 'gremlin'"):
        run_program_all(store, program, executor="gremlin")
    with pytest.raises(QueryValidationError):
        run_program_all(store, {"query_type": "spatial", "steps": [], "answer_step": 0})
    got = run_program_all(store, program, scenes="scene*")
    assert isinstance(got, MultiSceneResult)
    assert list(got) == ["scene0001_00", "scene0002_00"]
    assert len(got) == 2 and "other" not in got
    doc = got.to_dict()
    assert doc["scenes"] == 2 and doc["answered"] == 2
    assert [r["scene_id"] for r in doc["results"]] == ["scene0001_00", "scene0002_00"]


def test_empty_store_answers_nothing(store: GraphStore) -> None:
    for executor in ("sql", "sparql", "networkx"):
        got = run_program_all(store, COUNTERFACTUAL, executor=executor)
        assert len(got) == 0 and got.answered() == ()


def test_result_collection_is_a_sorted_mapping() -> None:
    program = GraphQuery.parse(COUNTERFACTUAL)
    results = {
        sid: NetworkxExecutor(_support_scene(sid, cup)).run(program)
        for sid, cup in (("a", True), ("b", False))
    }
    many = MultiSceneResult(program, (results["a"], results["b"]), "networkx")
    assert dict(many) == results and many.answers() == {"a": (3, 4), "b": ()}
    assert many == MultiSceneResult(program, (results["a"], results["b"]), "sql")
    with pytest.raises(KeyError):
        many["c"]
    with pytest.raises(ValueError, match="sorted by scene id"):
        MultiSceneResult(program, (results["b"], results["a"]), "networkx")
    with pytest.raises(ValueError, match="one per scene"):
        MultiSceneResult(program, (results["a"], results["a"]), "networkx")
