"""The SPARQL executor over many scenes: every scene's result (answer, step values, support
paths) equals the per-scene SPARQL executor's and the networkx reference's, on Oxigraph
and rdflib, for random programs over several random scenes; and the number of queries it
sends does not grow with the number of scenes."""

from __future__ import annotations

from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from graph_store.types import Entity, Relation, RelationType, SceneGraph, SceneMeta
from queries import GraphQuery
from queries.networkx_executor import NetworkxExecutor
from queries.sparql_endpoints import OxigraphEndpoint, RdflibEndpoint, SparqlEndpoint
from queries.sparql_executor import SparqlExecutor
from queries.sparql_many import run_sparql_many
from tests.queries.query_strategies import CATEGORIES, TEXTS, programs, scenes

BACKENDS: dict[str, type[OxigraphEndpoint] | type[RdflibEndpoint]] = {
    "oxigraph": OxigraphEndpoint,
    "rdflib": RdflibEndpoint,
}
#: Scene ids whose IRIs need escaping, and one that is a prefix of another.
SCENE_IDS = ("a", "a1", "b x' OR '1'='1", 'c scène/1 "q" \\', "d/entity/2")
_SETTINGS = {
    "deadline": None,
    "suppress_health_check": [HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
}


@st.composite
def scene_sets(draw: st.DrawFn) -> list[SceneGraph]:
    ids = draw(st.lists(st.sampled_from(SCENE_IDS), min_size=1, max_size=4, unique=True))
    return [draw(scenes(max_entities=7, scene_id=sid)) for sid in ids]


def _check(backend: str, graphs: list[SceneGraph], batch: list[GraphQuery]) -> None:
    endpoint = BACKENDS[backend].from_graphs(graphs)
    ids = [g.scene_id for g in graphs]
    for n, program in enumerate(batch):
        # every scene the endpoint holds, or (with a scene filter) all but the first
        every = n % 2 == 0 or len(ids) == 1
        chosen = ids if every else ids[1:]
        got = run_sparql_many(endpoint, chosen, program, all_scenes=every)
        assert sorted(got) == sorted(chosen)
        for g in graphs[len(ids) - len(chosen) :]:
            alone = SparqlExecutor(endpoint, g.scene_id).run(program)
            reference = NetworkxExecutor(g).run(program)
            result = got[g.scene_id]
            assert result.executor == "sparql"
            assert result == alone == reference, (
                f"{backend} on {g.scene_id!r} disagrees with the per-scene run of\n"
                f"{program.to_text()}\nmany {result.steps}\none  {alone.steps}\n"
                f"ref  {reference.steps}\n{result.support_paths} vs {reference.support_paths}"
            )


@pytest.mark.parametrize("backend", ["oxigraph", "rdflib"])
def test_every_scene_matches_its_own_run(backend: str) -> None:
    examples = 40 if backend == "oxigraph" else 15

    @settings(max_examples=examples, **_SETTINGS)  # type: ignore[arg-type]
    @given(graphs=scene_sets(), batch=st.lists(programs(), min_size=3, max_size=3))
    def check(graphs: list[SceneGraph], batch: list[GraphQuery]) -> None:
        _check(backend, graphs, batch)

    check()


@st.composite
def removals(draw: st.DrawFn) -> GraphQuery:
    """What falls when the entities of one category (or one text match) are removed."""
    pick: dict[str, Any] = (
        {"op": "filter_category", "inputs": [0], "value": draw(st.sampled_from(CATEGORIES))}
        if draw(st.booleans())
        else {"op": "match_text", "inputs": [0], "value": draw(st.sampled_from(TEXTS)), "k": 3}
    )
    steps = [{"op": "scene"}, pick, {"op": "fall_if_removed", "inputs": [1]}]
    steps.append({"op": "fall_if_removed", "inputs": [2]})
    return GraphQuery.parse({"query_type": "counterfactual", "steps": steps, "answer_step": 2})


@pytest.mark.parametrize("backend", ["oxigraph", "rdflib"])
def test_what_falls_matches_its_own_run(backend: str) -> None:
    examples = 20 if backend == "oxigraph" else 8

    @settings(max_examples=examples, **_SETTINGS)  # type: ignore[arg-type]
    @given(graphs=scene_sets(), batch=st.lists(removals(), min_size=3, max_size=3))
    def check(graphs: list[SceneGraph], batch: list[GraphQuery]) -> None:
        _check(backend, graphs, batch)

    check()


def _counting(base: type[Any]) -> type[Any]:
    class Counting(base):  # type: ignore[misc]
        """A real endpoint that counts the queries it is sent."""

        sent = 0

        def select(self, text: str) -> list[tuple[Any, ...]]:
            self.sent += 1
            return super().select(text)  # type: ignore[no-any-return]

        def iris(self, text: str) -> list[str]:
            self.sent += 1
            return super().iris(text)  # type: ignore[no-any-return]

        def ask(self, text: str) -> bool:
            self.sent += 1
            return super().ask(text)  # type: ignore[no-any-return]

    return Counting


def _room(scene_id: str, shift: float) -> SceneGraph:
    """A floor, a table on it and on a book, a cup on the table, a spoon on both."""

    def box(i: int, category: str, x: float, z: float, caption: str | None = None) -> Entity:
        x += shift
        return Entity(
            i, category, (x, 0.5 * i, z), (x - 0.4, 0.5 * i - 0.4, z - 0.4),
            (x + 0.4, 0.5 * i + 0.4, z + 0.4), caption=caption,
        )  # fmt: skip

    ents = (
        box(1, "floor", 0.0, 0.0),
        box(2, "table", 0.0, 1.0, "a wooden table"),
        box(3, "cup", 0.5, 2.0, "a red cup"),
        box(4, "book", -0.5, 2.0),
        box(5, "spoon", 0.5, 3.0),
    )
    rels = (
        Relation(2, 1, RelationType.SUPPORTED_BY),
        Relation(3, 2, RelationType.SUPPORTED_BY),
        Relation(2, 4, RelationType.SUPPORTS),
        Relation(5, 3, RelationType.SUPPORTED_BY),
        Relation(5, 2, RelationType.SUPPORTED_BY),
        Relation(3, 4, RelationType.NEAR),
    )
    return SceneGraph(SceneMeta(scene_id), ents, rels)


PROGRAMS = {
    "spatial": {
        "query_type": "spatial",
        "answer_step": 7,
        "steps": [
            {"op": "scene"},
            {"op": "filter_category", "inputs": [0], "value": "Cup"},
            {"op": "filter_category", "inputs": [0], "value": "book"},
            {"op": "relate", "inputs": [0, 2], "relation": "left_of"},
            {"op": "relate", "inputs": [1, 2], "relation": "near"},
            {"op": "argmin", "inputs": [0], "metric": "distance", "k": 2},
            {"op": "match_text", "inputs": [0], "value": "red cup", "k": 2},
            {"op": "union", "inputs": [3, 4, 5, 6]},
            {"op": "count", "inputs": [7]},
            {"op": "coalesce", "inputs": [3, 4, 6]},
        ],
    },
    "closure": {
        "query_type": "counterfactual",
        "answer_step": 3,
        "steps": [
            {"op": "scene"},
            {"op": "filter_attribute", "inputs": [0], "value": "color=red"},
            {"op": "filter_category", "inputs": [0], "value": "table"},
            {"op": "support_closure", "inputs": [2]},
            {"op": "argmax", "inputs": [3, 2], "metric": "horizontal_distance"},
            {"op": "middle", "inputs": [3, 2], "metric": "distance"},
            {"op": "relate_between", "inputs": [0, 2, 3]},
            {"op": "exists", "inputs": [6]},
        ],
    },
}
FALL = {
    "query_type": "counterfactual",
    "answer_step": 2,
    "steps": [
        {"op": "scene"},
        {"op": "filter_category", "inputs": [0], "value": "table"},
        {"op": "fall_if_removed", "inputs": [1]},
    ],
}


def _queries(backend: str, graphs: list[SceneGraph], program: dict[str, Any]) -> int:
    endpoint: SparqlEndpoint = _counting(BACKENDS[backend]).from_graphs(graphs)
    results = run_sparql_many(endpoint, [g.scene_id for g in graphs], program)
    for g in graphs:
        assert results[g.scene_id] == NetworkxExecutor(g).run(program)
    return int(endpoint.sent)  # type: ignore[attr-defined]


@pytest.mark.parametrize("backend", ["oxigraph", "rdflib"])
@pytest.mark.parametrize("name", sorted(PROGRAMS))
def test_queries_do_not_grow_with_scenes(backend: str, name: str) -> None:
    program = PROGRAMS[name]
    rooms = [_room(f"scene{n:04d}_00", 0.1 * n) for n in range(12)]
    one, many = _queries(backend, rooms[:1], program), _queries(backend, rooms, program)
    assert one == many
    # the per-scene executor on the same dataset sends at least as many for each scene
    counting = _counting(BACKENDS[backend]).from_graphs(rooms)
    for n, g in enumerate(rooms, 1):
        assert SparqlExecutor(counting, g.scene_id).run(program) == NetworkxExecutor(g).run(program)
        assert counting.sent >= n * many


@pytest.mark.parametrize("backend", ["oxigraph", "rdflib"])
def test_fall_if_removed_is_one_query_per_round(backend: str) -> None:
    rooms = [_room(f"scene{n:04d}_00", 0.0) for n in range(10)]
    # the spoon falls in round 2 (on the cup), so three rounds find something or nothing
    rounds = 3
    # entities, categories, the filter, the rounds, the fallen entities' supporters
    assert _queries(backend, rooms, FALL) == 3 + rounds + 1
    bare = SceneGraph(SceneMeta("scene9999_00"), rooms[0].entities[:2], rooms[0].relations[:1])
    assert _queries(backend, [*rooms, bare], FALL) == 3 + rounds + 1
    got = run_sparql_many(OxigraphEndpoint.from_graphs([bare, rooms[0]]), ["scene9999_00"], FALL)
    assert list(got) == ["scene9999_00"] and got["scene9999_00"].answer == ()
