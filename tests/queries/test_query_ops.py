"""Every op and relation on a hand-built scene, with answers worked out by hand, on every
backend.

Layout (top view, x right, y up; the scene centre is (0, 0), from the floor's box)::

    y= 1               towel[2]
    y= 0   mug[6]  floor[0]  cup[5]  Sink[1]  towel[4]
    y=-1                             towel[3]
    y=-2       chair[7] table[9] chair[8]
          x=-2  -1   0     1      2      3

Seen from the centre looking at the sink (+x): towel 2 is on its left, towel 3 on its
right, towel 4 behind it, the cup in front of it; towel 2 is the leftmost towel, towel 3 the
rightmost.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import pytest

from graph_store.errors import SceneNotFound
from graph_store.types import Attribute, Entity, Relation, SceneGraph, SceneMeta
from queries import Executor, GraphQuery

MakeExecutor = Callable[[SceneGraph], Executor]


def box(i: int, cat: str, x: float, y: float, z: float, h: float = 0.5, **kw: object) -> Entity:
    """A 0.5 x 0.5 x h box centred on (x, y, z)."""
    lo, hi = (x - 0.25, y - 0.25, z - h / 2), (x + 0.25, y + 0.25, z + h / 2)
    return Entity(i, cat, (x, y, z), lo, hi, **kw)  # type: ignore[arg-type]


def scene() -> SceneGraph:
    ents = [
        Entity(0, "floor", (0.0, 0.0, -0.05), (-4.0, -4.0, -0.1), (4.0, 4.0, 0.0)),
        box(1, "Sink", 2, 0, 0.8, attributes=(Attribute("color", "white"),)),
        box(2, "towel", 2, 1, 0.8),
        box(3, "towel", 2, -1, 0.8),
        box(4, "towel", 3, 0, 0.8),
        box(5, "cup", 1, 0, 0.8, h=0.1),
        box(6, "mug", -2, 0, 0.8, h=0.1, caption="a red cup",
            attributes=(Attribute("color", "Red"), Attribute("affordance", "drink"))),
        box(7, "chair", -1, -2, 0.45, h=0.9, attributes=(Attribute("affordance", "sit"),)),
        box(8, "chair", 1, -2, 0.45, h=0.9, attributes=(Attribute("affordance", " Sit"),)),
        box(9, "table", 0, -2, 0.4, h=0.8),
    ]  # fmt: skip
    rels = [Relation(1, 2, "near"), Relation(1, 4, "below"), Relation(3, 1, "next_to")]
    return SceneGraph(SceneMeta("ops"), tuple(ents), tuple(rels))


HEAD = """query spatial
v0 = scene()
v1 = filter_category(v0, " SINK ")
v2 = filter_category(v0, "towel")
v3 = filter_category(v0, "chair")
"""

CASES = [
    ("v4 = count(v1)", 1),
    ("v4 = union(v1, v2)", (1, 2, 3, 4)),
    ('v4 = filter_attribute(v0, "COLOR = red")', (6,)),
    ('v4 = filter_affordance(v0, "sit")', (7, 8)),
    ('v4 = match_text(v0, "red cup")', (6,)),
    ('v4 = match_text(v0, "red cup", k=2)', (5, 6)),
    ('v4 = match_text(v0, "qqq", k=2)', ()),
    ("v4 = relate(v2, v1, near)", (2,)),
    ("v4 = relate(v1, v2, near)", (1,)),
    ("v4 = relate(v2, v1, above)", (4,)),
    ("v4 = relate(v1, v2, below)", (1,)),
    ("v4 = relate(v2, v1, next_to)", (3,)),
    ("v4 = relate(v2, v1, supported_by)", ()),
    ("v4 = relate(v2, v1, left_of)", (2,)),
    ("v4 = relate(v2, v1, right_of)", (3,)),
    ("v4 = relate(v2, v1, behind)", (4,)),
    ("v4 = relate(v0, v1, in_front_of)", (0, 5, 6, 7)),
    ("v4 = relate(v0, v1, right_of)", (3, 8, 9)),
    ("v4 = relate(v2, v1, right_of, viewpoint=(4.0, 0.0, 1.0)->(2.0, 0.0, 1.0))", (2,)),
    ("v4 = relate(v2, v1, in_front_of, viewpoint=(4.0, 0.0, 1.0)->(2.0, 0.0, 1.0))", (4,)),
    ("v4 = relate_between(v0, v3, v3)", (9,)),
    # 0.3 x |ab| of lateral slack: between the sink and chair 7 lie the cup, towel 3
    # (0.83 off a 3.6 long line) and the table
    ("v4 = relate_between(v0, v1, v3)", (3, 5, 9)),
    ("v4 = argmax(v3, height)", (7,)),
    ("v4 = argmax(v3, height, k=2)", (7, 8)),
    ("v4 = argmin(v0, z)", (0,)),
    ("v4 = argmin(v0, x)", (6,)),
    ("v4 = argmax(v0, y)", (2,)),
    ("v4 = argmin(v0, y, k=3)", (7, 8, 9)),
    ("v4 = argmax(v0, volume)", (0,)),
    # from the centre looking at the sink (+x), right is -y
    ("v4 = argmax(v2, rightward, viewpoint=(0.0, 0.0, 1.0)->(2.0, 0.0, 1.0))", (3,)),
    ("v4 = argmin(v2, rightward, viewpoint=(0.0, 0.0, 1.0)->(2.0, 0.0, 1.0))", (2,)),
    # looking at (1, 2), right is (2, -1): towels 2, 3, 4 at 3, 5 and 6 to the right
    ("v4 = argmax(v2, rightward, k=2, viewpoint=(0.0, 0.0, 1.0)->(1.0, 2.0, 1.0))", (3, 4)),
    ("v4 = argmin(v2, rightward, viewpoint=(0.0, 0.0, 1.0)->(1.0, 2.0, 1.0))", (2,)),
    # ahead of the centre towards the sink (+x): towels 2 and 3 at x = 2, towel 4 at x = 3
    ("v4 = argmax(v2, forward, viewpoint=(0.0, 0.0, 1.0)->(2.0, 0.0, 1.0))", (4,)),
    ("v4 = argmin(v2, forward, k=2, viewpoint=(0.0, 0.0, 1.0)->(2.0, 0.0, 1.0))", (2, 3)),
    # from behind the sink looking back (-x), towel 4 is the nearest ahead
    ("v4 = argmin(v2, forward, viewpoint=(4.0, 0.0, 1.0)->(2.0, 0.0, 1.0))", (4,)),
    ("v4 = argmax(v0, forward, viewpoint=(4.0, 0.0, 1.0)->(2.0, 0.0, 1.0))", (6,)),
    ("v4 = argmin(v2, v1, distance)", (2,)),
    ("v4 = argmin(v2, v1, distance, k=2)", (2, 3)),
    ("v4 = argmin(v0, v1, distance, k=2)", (2, 3)),
    ("v4 = argmax(v0, distance)", (4,)),
    ("v4 = argmin(v0, distance, k=2)", (0, 5)),
    ("v4 = argmin(v1, v1, distance)", ()),
    ("v4 = relate(v2, v1, near)\nv5 = difference(v2, v4)", (3, 4)),
    ("v4 = argmin(v2, v1, distance, k=2)\nv5 = intersect(v2, v4, v0)", (2, 3)),
    ('v4 = filter_category(v0, "nothing")\nv5 = exists(v4)', False),
    ("v4 = exists(v3)", True),
    ("v4 = count(v0)", 10),
]


@pytest.fixture
def executor(make_any: MakeExecutor) -> Executor:
    return make_any(scene())


def test_every_case(executor: Executor) -> None:
    """All cases on one executor (one store per backend)."""
    for body, expected in CASES:
        program = GraphQuery.from_text(HEAD + body)
        result = executor.run(program)
        assert result.answer == expected, f"{body}: {result.answer} != {expected}"
        assert type(result.answer) is type(expected)
        assert result.steps[1] == (1,) and result.steps[2] == (2, 3, 4)


#: ``HEAD`` and two empty sets (v4, v5) for ``coalesce``.
COALESCE_HEAD = HEAD + 'v4 = filter_category(v0, "nothing")\nv5 = relate(v2, v1, supported_by)\n'
COALESCE_CASES = [
    # the first input non-empty: the first
    ("v6 = coalesce(v1, v2)", (1,)),
    ("v6 = coalesce(v2, v4)", (2, 3, 4)),
    # the first empty, the second not: the second
    ("v6 = coalesce(v4, v3)", (7, 8)),
    ("v6 = coalesce(v5, v0)", tuple(range(10))),
    # all empty: empty
    ("v6 = coalesce(v4, v5)", ()),
    ("v6 = coalesce(v4, v4, v5)", ()),
    # three inputs and more: the first non-empty, whatever follows it
    ("v6 = coalesce(v4, v5, v3, v2)", (7, 8)),
    ("v6 = coalesce(v5, v4, v5, v4, v5, v4, v5, v1)", (1,)),
    ("v6 = coalesce(v2, v4, v3)", (2, 3, 4)),
    # an input given twice
    ("v6 = coalesce(v3, v3)", (7, 8)),
    ("v6 = coalesce(v4, v2, v4)", (2, 3, 4)),
    # an input that may list an id twice (relate), and a coalesce read by later steps
    ("v6 = relate(v0, v1, near)\nv7 = coalesce(v4, v6)", (2,)),
    ("v6 = coalesce(v4, v2)\nv7 = relate(v6, v1, near)", (2,)),
    ("v6 = coalesce(v4, v5, v3)\nv7 = count(v6)", 2),
    ("v6 = coalesce(v4, v5)\nv7 = exists(v6)", False),
]


def test_coalesce_takes_the_first_non_empty_input(executor: Executor) -> None:
    for body, expected in COALESCE_CASES:
        result = executor.run(GraphQuery.from_text(COALESCE_HEAD + body))
        assert result.answer == expected, f"{body}: {result.answer} != {expected}"
        assert type(result.answer) is type(expected)
        assert result.steps[1:6] == ((1,), (2, 3, 4), (7, 8), (), ())


#: ``HEAD`` and an empty set (v4) for ``middle``.
MIDDLE_HEAD = HEAD + 'v4 = filter_category(v0, "nothing")\n'
MIDDLE_CASES = [
    # an odd count: the middle one (towels by y: 3, 4, 2)
    ("v5 = middle(v2, y)", (4,)),
    # an even count: the two middle ones (x: 6, 7, 0, 9, 5, 8, 1, 2, 3, 4; 5 and 8 tie)
    ("v5 = middle(v0, x)", (5, 8)),
    ("v5 = middle(v3, height)", (7, 8)),
    # one member: itself; none: none
    ("v5 = middle(v1, z)", (1,)),
    ("v5 = middle(v4, z)", ()),
    # ties broken by id, in argmin's order: towels 2 and 3 tie at x = 2 (argmax's order
    # would put 2 in the middle)
    ("v5 = middle(v2, x)", (3,)),
    ("v5 = middle(v0, z)", (1, 2)),  # z: 0, 9, 7, 8, then 1 to 6 tied
    # a reference set: the sink is the only reference, so it is dropped; the rest by
    # squared distance: 2, 3, 4, 5 (1), 0 (4.7225), 8, 9, 7, 6
    ("v5 = middle(v0, v1, distance)", (0,)),
    ("v5 = union(v1, v2)\nv6 = middle(v5, v1, distance)", (3,)),
    ("v5 = middle(v1, v1, distance)", ()),
    ("v5 = middle(v1, v4, distance)", ()),
    # no reference set: to the scene centre
    ("v5 = middle(v2, distance)", (3,)),
    # from the centre looking at the sink (+x), right is -y: towel 4 between 2 and 3
    ("v5 = middle(v2, rightward, viewpoint=(0.0, 0.0, 1.0)->(2.0, 0.0, 1.0))", (4,)),
    # looking at (1, 2): towels 2, 3, 4 at 3, 5 and 6 to the right
    ("v5 = middle(v2, rightward, viewpoint=(0.0, 0.0, 1.0)->(1.0, 2.0, 1.0))", (3,)),
    # from behind the sink looking back (-x): ahead 4, then 1, 2, 3, then 5, 8, ...
    ("v5 = middle(v0, forward, viewpoint=(4.0, 0.0, 1.0)->(2.0, 0.0, 1.0))", (5, 8)),
    # read by later steps
    ("v5 = middle(v0, x)\nv6 = count(v5)", 2),
    ("v5 = middle(v0, v1, distance)\nv6 = relate(v0, v5, near)", ()),
    ("v5 = middle(v2, y)\nv6 = argmin(v0, v5, distance, k=2)", (1, 2)),
]


def test_middle_keeps_the_middle_of_argmins_order(executor: Executor) -> None:
    for body, expected in MIDDLE_CASES:
        result = executor.run(GraphQuery.from_text(MIDDLE_HEAD + body))
        assert result.answer == expected, f"{body}: {result.answer} != {expected}"
        assert type(result.answer) is type(expected)
        assert result.steps[1:5] == ((1,), (2, 3, 4), (7, 8), ())


def test_results_carry_every_step_and_explain(executor: Executor) -> None:
    result = executor.run(GraphQuery.from_text(HEAD + "v4 = relate(v2, v1, left_of)"))
    assert result.steps == (tuple(range(10)), (1,), (2, 3, 4), (7, 8), (2,))
    assert result.entity_ids == (2,)
    assert result.step_size(0) == 10
    lines = result.explain().splitlines()
    assert lines[2] == 'v1 = filter_category(v0, " SINK ")  # 1 entity: 1'
    assert lines[-2] == "v4 = relate(v2, v1, left_of)  # 1 entity: 2"
    document = result.to_dict()
    assert document["answer"] == [2] and document["steps"][2] == [2, 3, 4]


def test_sql_compiles_a_program_once_per_scene_version(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A program run again on the unchanged scene reuses its statement; saving the scene
    again compiles it anew; a fixpoint (``fall_if_removed``) is compiled every run."""
    from graph_store.repository import open_store
    from queries import sql_executor
    from queries.sql_executor import SqlExecutor

    compiled: list[int] = []
    real = sql_executor._SqlRun._compile

    def counting(self: object, i: int, step: object) -> object:
        compiled.append(i)
        return real(self, i, step)  # type: ignore[arg-type]

    monkeypatch.setattr(sql_executor._SqlRun, "_compile", counting)
    spatial = GraphQuery.from_text(HEAD + "v4 = relate(v2, v1, left_of)")
    falls = GraphQuery.from_text(
        'query counterfactual\nv0 = scene()\nv1 = filter_category(v0, "table")\n'
        "v2 = fall_if_removed(v1)\nreturn v2"
    )
    first = scene()
    with open_store(f"sqlite:///{tmp_path / 'prepared.db'}") as store:
        store.save_scene(first)
        sql = SqlExecutor(store.engine, first.scene_id)
        answers = [sql.run(spatial).answer for _ in range(3)]
        assert answers == [(2,)] * 3 and len(compiled) == 5
        for _ in range(2):
            sql.run(falls)
        assert len(compiled) == 5 + 2 * 3
        # towel 2 becomes a cup: the kept statement would be stale
        renamed = tuple(replace(e, category="cup") if e.id == 2 else e for e in first.entities)
        store.save_scene(replace(first, entities=renamed), if_exists="replace")
        assert sql.run(spatial).answer == () and len(compiled) == 5 + 2 * 3 + 5


@pytest.mark.parametrize(
    "backend", ["sqlite", pytest.param("postgres", marks=pytest.mark.postgres)]
)
def test_sql_reads_the_scene_ids_again_after_the_scene_is_saved_again(
    backend: str, request: pytest.FixtureRequest, tmp_path: Path
) -> None:
    from graph_store.repository import open_store
    from queries.sql_executor import SqlExecutor

    url = (
        f"sqlite:///{tmp_path / 'ids.db'}"
        if backend == "sqlite"
        else str(request.getfixturevalue("postgres_url"))
    )
    program = GraphQuery.from_text(
        'query spatial\nv0 = scene()\nv1 = filter_category(v0, "towel")\nreturn v0'
    )
    first = scene()
    with open_store(url) as store:
        store.save_scene(first, if_exists="replace")
        sql = SqlExecutor(store.engine, first.scene_id)
        assert sql.run(program).answer == tuple(e.id for e in first.entities)
        assert sql.run(program).answer == tuple(e.id for e in first.entities)  # cached
        # the same number of entities under other ids, then fewer: both read again
        shifted = tuple(
            Entity(e.id + 100, e.category, e.centroid, e.bbox_min, e.bbox_max)
            for e in first.entities
        )
        store.save_scene(SceneGraph(first.meta, shifted), if_exists="replace")
        assert sql.run(program).answer == tuple(e.id for e in shifted)
        store.save_scene(SceneGraph(first.meta, shifted[:3]), if_exists="replace")
        assert sql.run(program).answer == (100, 101, 102)
        store.delete_scene(first.scene_id)
        # a deleted scene is no empty scene: the executor says it is gone
        with pytest.raises(SceneNotFound, match="no scene"):
            sql.run(program)


def test_box_distance_measures_to_the_reference_surface(make_any: MakeExecutor) -> None:
    """A wall 6 m long: the chair against its end is metres from its centroid but 0.35 m from
    the wall; a picture hung on it is inside its box (0)."""
    wall = Entity(3, "wall", (0.0, 2.0, 1.25), (-3.0, 1.95, 0.0), (3.0, 2.05, 2.5))
    ents = (
        box(1, "thing", 2.5, 1.6, 0.45),  # against the wall's end: centroid 7.05, box 0.1225
        box(2, "thing", 0.0, 0.5, 0.45),  # 1.45 m out from its middle: 2.89, box 2.1025
        wall,
        box(4, "thing", -2.0, 2.0, 1.5),  # on the wall: 4.0625, box 0 (inside)
        box(5, "thing", 5.0, 2.0, 0.45),  # past its end, in line: 25.64, box 4.0
    )
    executor = make_any(SceneGraph(SceneMeta("boxed"), ents))
    head = 'query spatial\nv0 = scene()\nv1 = filter_category(v0, "wall")\n'
    head += 'v2 = filter_category(v0, "thing")\n'
    cases = [
        ("v3 = argmin(v2, v1, distance)", (2,)),
        ("v3 = argmin(v2, v1, box_distance)", (4,)),
        ("v3 = argmin(v2, v1, box_distance, k=2)", (1, 4)),
        ("v3 = argmin(v2, v1, box_distance, k=3)", (1, 2, 4)),
        ("v3 = argmax(v2, v1, box_distance)", (5,)),
        # the wall itself is not its own reference: 'walls closest to the wall' keep the others
        ("v3 = argmin(v1, v1, box_distance)", ()),
        # no reference set: to the scene centre (1.125, 1.25, 1.25), a point, as 'distance'
        ("v3 = argmin(v2, box_distance)", (2,)),
        ("v3 = argmin(v2, distance)", (2,)),
        ("v3 = argmax(v2, box_distance, k=2)", (4, 5)),
    ]
    for body, expected in cases:
        assert executor.run(GraphQuery.from_text(head + body)).answer == expected, body


def test_box_centroid_distance_breaks_box_ties_by_centroid(make_any: MakeExecutor) -> None:
    """A long, shallow bookshelf: a chair 0.3 m in front of it is nearer than one 0.65 m in
    front whose centroid is nearer the shelf's; of two chairs whose centroids lie inside
    its box (both at box distance 0), the one nearer its centroid is nearer."""
    ents = (
        Entity(1, "bookshelf", (0.0, 0.0, 1.0), (-1.0, -0.25, 0.0), (1.0, 0.25, 2.0)),
        box(10, "chair", 0.9, 0.55, 0.45),  # box 0.09, centroid 1.415
        box(11, "chair", 0.0, 0.9, 0.45),  # box 0.4225, centroid 1.1125
        box(12, "chair", 0.6, 0.0, 0.45),  # inside: box 0, centroid 0.6625
        box(13, "chair", -0.5, 0.1, 0.45),  # inside: box 0, centroid 0.5625
    )
    executor = make_any(SceneGraph(SceneMeta("shelf"), ents))
    head = 'query spatial\nv0 = scene()\nv1 = filter_category(v0, "bookshelf")\n'
    head += 'v2 = filter_category(v0, "chair")\n'
    cases = [
        ("v3 = argmin(v2, v1, box_centroid_distance)", (13,)),
        ("v3 = argmin(v2, v1, box_distance)", (12,)),  # a tie, broken by id
        ("v3 = argmin(v2, v1, box_centroid_distance, k=3)", (10, 12, 13)),
        ("v3 = argmin(v2, v1, distance, k=3)", (11, 12, 13)),
        ("v3 = argmax(v2, v1, box_centroid_distance)", (11,)),
        # no reference set: to the scene centre, a point, as 'distance'
        ("v3 = argmin(v2, box_centroid_distance, k=2)", (11, 13)),
        ("v3 = argmin(v2, distance, k=2)", (11, 13)),
    ]
    for body, expected in cases:
        assert executor.run(GraphQuery.from_text(head + body)).answer == expected, body


def test_end_and_corner_distance_measure_to_the_footprint(make_any: MakeExecutor) -> None:
    """A table long along x and a desk long along y: "the chair at the end of the table" is
    the one by the middle of a short edge, "at the corner" the one by a corner, "closest"
    the one by the middle of a long side."""
    ents = (
        Entity(1, "table", (0.0, 0.0, 0.4), (-1.0, -0.5, 0.0), (1.0, 0.5, 0.8)),
        Entity(2, "desk", (6.0, 0.0, 0.4), (5.6, -1.0, 0.0), (6.4, 1.0, 0.8)),
        box(10, "chair", 1.4, 0.0, 0.45),  # table: end 0.16, corner 0.41, centroid 1.96
        box(11, "chair", 0.8, 0.85, 0.45),  # table: end 0.7625, corner 0.1625, 1.3625
        box(12, "chair", 0.0, -0.9, 0.45),  # table: end 1.81, corner 1.16, centroid 0.81
        box(13, "chair", 6.0, 1.35, 0.45),  # desk: end 0.1225, corner 0.2825, 1.8225
        box(14, "chair", 6.75, 0.0, 0.45),  # desk: end 1.5625, corner 1.1225, 0.5625
    )
    executor = make_any(SceneGraph(SceneMeta("footprints"), ents))
    head = 'query spatial\nv0 = scene()\nv1 = filter_category(v0, "table")\n'
    head += 'v2 = filter_category(v0, "chair")\nv3 = filter_category(v0, "desk")\n'
    cases = [
        ("v4 = argmin(v2, v1, distance)", (12,)),
        ("v4 = argmin(v2, v1, end_distance)", (10,)),
        ("v4 = argmin(v2, v1, end_distance, k=2)", (10, 11)),
        ("v4 = argmin(v2, v1, corner_distance)", (11,)),
        ("v4 = argmin(v2, v1, corner_distance, k=2)", (10, 11)),
        ("v4 = argmax(v2, v1, end_distance)", (14,)),
        # the desk runs along y: its ends are across y
        ("v4 = argmin(v2, v3, distance)", (14,)),
        ("v4 = argmin(v2, v3, end_distance)", (13,)),
        ("v4 = argmin(v2, v3, corner_distance)", (13,)),
        # several references: the nearest end of any of them
        ("v4 = union(v1, v3)\nv5 = argmin(v2, v4, end_distance, k=2)", (10, 13)),
    ]
    for body, expected in cases:
        assert executor.run(GraphQuery.from_text(head + body)).answer == expected, body


def test_segment_distance_ranks_by_the_line_between_two_ends(make_any: MakeExecutor) -> None:
    """Two trash cans between a desk and a door: the one beside the door is nearer either
    end, the one on the line between them is most squarely between; with two doors, the
    nearest segment of any desk-door pair counts; an end is never measured to itself."""
    ents = (
        box(1, "desk", 0.0, 0.0, 0.4),
        box(2, "door", 4.0, 0.0, 1.0),
        box(10, "trash can", 3.6, 0.5, 0.2),  # beside the door: segment 0.25, door 0.41
        box(11, "trash can", 2.0, 0.2, 0.2),  # on the way: segment 0.04, ends 4.04
        box(12, "trash can", 6.0, 0.1, 0.2),  # past the door: segment 4.01 (to the door)
        box(3, "door", 2.0, 3.0, 1.0),  # a second door; its segments pass far from 11
    )
    executor = make_any(SceneGraph(SceneMeta("ends"), ents))
    head = 'query spatial\nv0 = scene()\nv1 = filter_category(v0, "desk")\n'
    head += 'v2 = filter_category(v0, "door")\nv3 = filter_category(v0, "trash can")\n'
    cases = [
        ("v4 = union(v1, v2)\nv5 = argmin(v3, v4, distance)", (10,)),
        ("v4 = argmin(v3, v1, v2, segment_distance)", (11,)),
        ("v4 = argmin(v3, v2, v1, segment_distance)", (11,)),  # either way round
        ("v4 = argmin(v3, v1, v2, segment_distance, k=2)", (10, 11)),
        ("v4 = argmax(v3, v1, v2, segment_distance)", (12,)),
        ("v4 = middle(v3, v1, v2, segment_distance)", (10,)),
        # the two doors as both ends: the segment between them (10 lies 0.06 m off it),
        # never a door to itself
        ("v4 = argmin(v3, v2, v2, segment_distance)", (10,)),
        # the candidates as ends: each is measured to segments between the others only
        # (10 to 11-12: 0.116; 11 and 12 to segments ending at 10: 2.65, 5.92)
        ("v4 = argmin(v3, v3, v3, segment_distance)", (10,)),
        # one end and nothing at the other: no segment, nothing ranked
        ('v4 = filter_category(v0, "sofa")\nv5 = argmin(v3, v1, v4, segment_distance)', ()),
    ]
    for body, expected in cases:
        assert executor.run(GraphQuery.from_text(head + body)).answer == expected, body


def test_horizontal_distance_ignores_height(make_any: MakeExecutor) -> None:
    """A lamp hung 5 m over the anchor is horizontally nearest; a cup beside it is nearest in 3D."""
    ents = (
        box(0, "table", 0.0, 0.0, 0.0),
        box(1, "thing", 1.0, 0.0, 0.0),  # beside: 3D 1.0, horizontal 1.0
        box(2, "thing", 0.2, 0.0, 5.0),  # overhead: 3D 5.004, horizontal 0.2
        box(3, "thing", -3.0, 0.0, 0.0),  # far away: 3D 3.0, horizontal 3.0
    )
    executor = make_any(SceneGraph(SceneMeta("flat"), ents))
    head = 'query spatial\nv0 = scene()\nv1 = filter_category(v0, "table")\n'
    head += 'v2 = filter_category(v0, "thing")\n'
    cases = [
        ("v3 = argmin(v2, v1, distance)", (1,)),
        ("v3 = argmin(v2, v1, horizontal_distance)", (2,)),
        ("v3 = argmin(v2, v1, horizontal_distance, k=2)", (1, 2)),
        ("v3 = argmax(v2, v1, distance)", (2,)),
        ("v3 = argmax(v2, v1, horizontal_distance)", (3,)),
        # no reference set: to the scene centre (-1, 0, 2.5), horizontally 2.0, 1.2 and 2.0
        # away; the tie of 1 and 3 goes to the smaller id
        ("v3 = argmin(v2, horizontal_distance)", (2,)),
        ("v3 = argmax(v2, horizontal_distance)", (1,)),
    ]
    for body, expected in cases:
        assert executor.run(GraphQuery.from_text(head + body)).answer == expected, body


def test_length_is_the_longer_horizontal_side(make_any: MakeExecutor) -> None:
    """A bench long along x, a table long along y, a tall cabinet: length is the longer of
    the footprint's two sides, whichever axis; height and volume do not enter it."""
    ents = (
        Entity(0, "thing", (0.0, 0.0, 0.25), (-1.0, -0.2, 0.0), (1.0, 0.2, 0.5)),  # 2.0 long
        Entity(1, "thing", (3.0, 0.0, 0.4), (2.5, -1.2, 0.0), (3.5, 1.2, 0.8)),  # 2.4 long
        Entity(2, "thing", (6.0, 0.0, 1.0), (5.7, -0.3, 0.0), (6.3, 0.3, 2.0)),  # 0.6, tall
    )
    executor = make_any(SceneGraph(SceneMeta("lengths"), ents))
    head = 'query spatial\nv0 = scene()\nv1 = filter_category(v0, "thing")\n'
    cases = [
        ("v2 = argmax(v1, length)", (1,)),
        ("v2 = argmax(v1, length, k=2)", (0, 1)),
        ("v2 = argmin(v1, length)", (2,)),
        ("v2 = middle(v1, length)", (0,)),
        ("v2 = argmax(v1, height)", (2,)),
    ]
    for body, expected in cases:
        assert executor.run(GraphQuery.from_text(head + body)).answer == expected, body
