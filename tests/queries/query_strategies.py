"""Hypothesis strategies for the query tests: small scene graphs built to produce ties,
empty sets, support cycles and objects on two supporters, and valid random programs over
them."""

from __future__ import annotations

import math
from typing import Any

from hypothesis import strategies as st

from graph_store.types import (
    STORED_RELATION_TYPES,
    Attribute,
    Entity,
    Relation,
    RelationType,
    SceneGraph,
    SceneMeta,
)
from queries import GraphQuery, Metric, Op, QueryType
from queries.model import MIN_VIEW_DISTANCE

# Categories with case/whitespace variants (they normalise alike) and characters that
# need escaping in SQL and SPARQL.
CATEGORIES = [
    "floor", "Floor ", "wall", "ceiling", "table", "TABLE", "cup", "sink", "towel",
    'say "hi" \\ o/', "line\nbreak", "café", "chair  leg", "x' OR '1'='1",
]  # fmt: skip
CAPTIONS = ["a red cup", "table", "towel rack", "", "sink\tunit"]
ATTRIBUTES = [
    ("color", "red"), ("Color", "Red "), ("color", "blue"), ("affordance", "sit"),
    ("affordance", "pour"), ("Affordance", "SIT"), ("material", "wood"),
]  # fmt: skip
VALUES = ["table", " table ", "Floor", "cup", "sink", "towel", "wall", 'say "hi" \\ o/',
          "line break", "line\nbreak", "café", "chair leg", "nothing", "x' OR '1'='1"]  # fmt: skip
ATTRIBUTE_VALUES = ["color=red", "COLOR = red", "color=blue", "material=wood", "size=big"]
AFFORDANCES = ["sit", "pour", "SIT ", "fly"]
TEXTS = ["cup", "tabel", "towel", "red cup", "sink", "zzz", "chair"]
# PostgreSQL raises on floating-point underflow (a product below ~1e-308), so coordinates
# are kept away from the subnormal range; everything else about them is arbitrary.
COORDS = st.one_of(
    st.sampled_from([-1.0, 0.0, 0.5, 1.0, 2.0]),
    st.floats(-5.0, 5.0, allow_nan=False, allow_infinity=False).filter(
        lambda x: x == 0.0 or abs(x) > 1e-9
    ),
)
HALF = st.sampled_from([0.0, 0.25, 0.5, 1.0])
SCENE_ID = 'parity scène/1 "q"'


@st.composite
def entities(draw: st.DrawFn, entity_id: int) -> Entity:
    centre = [draw(COORDS) for _ in range(3)]
    half = [draw(HALF) for _ in range(3)]
    attrs = draw(st.lists(st.sampled_from(ATTRIBUTES), max_size=3, unique=True))
    return Entity(
        id=entity_id,
        category=draw(st.sampled_from(CATEGORIES)),
        centroid=tuple(centre),
        bbox_min=tuple(c - h for c, h in zip(centre, half, strict=True)),
        bbox_max=tuple(c + h for c, h in zip(centre, half, strict=True)),
        external_id=str(entity_id),
        caption=draw(st.none() | st.sampled_from(CAPTIONS)),
        attributes=tuple(Attribute(k, v) for k, v in attrs),
    )


SUPPORT = [RelationType.SUPPORTED_BY, RelationType.SUPPORTS]


@st.composite
def scenes(draw: st.DrawFn, max_entities: int = 9, scene_id: str = SCENE_ID) -> SceneGraph:
    ids = draw(st.lists(st.integers(0, 40), max_size=max_entities, unique=True))
    ents = [draw(entities(i)) for i in ids]
    triples: set[tuple[int, str, int]] = set()
    if len(ids) >= 2:
        pick = st.sampled_from(ids)
        kinds = st.sampled_from([*SUPPORT, *SUPPORT, *STORED_RELATION_TYPES])
        for src, rel, dst in draw(st.lists(st.tuples(pick, kinds, pick), max_size=3 * len(ids))):
            if src != dst:
                triples.add((src, rel.value, dst))
    rels = [Relation(s, d, t) for s, t, d in sorted(triples)]
    return SceneGraph(SceneMeta(scene_id), tuple(ents), tuple(rels))


def _refs(draw: st.DrawFn, sets: list[int], n: int) -> list[int]:
    return [draw(st.sampled_from(sets)) for _ in range(n)]


@st.composite
def steps_for(draw: st.DrawFn, op: Op, sets: list[int]) -> dict[str, Any]:
    """One step of ``op`` reading earlier set steps."""
    step: dict[str, Any] = {"op": op.value}
    if op is Op.FILTER_CATEGORY:
        step.update(inputs=_refs(draw, sets, 1), value=draw(st.sampled_from(VALUES)))
    elif op is Op.FILTER_ATTRIBUTE:
        step.update(inputs=_refs(draw, sets, 1), value=draw(st.sampled_from(ATTRIBUTE_VALUES)))
    elif op is Op.FILTER_AFFORDANCE:
        step.update(inputs=_refs(draw, sets, 1), value=draw(st.sampled_from(AFFORDANCES)))
    elif op is Op.MATCH_TEXT:
        step.update(inputs=_refs(draw, sets, 1), value=draw(st.sampled_from(TEXTS)))
        step["k"] = draw(st.none() | st.integers(1, 4))
    elif op is Op.RELATE:
        rel = draw(st.sampled_from(list(RelationType)))
        step.update(inputs=_refs(draw, sets, 2), relation=rel.value)
        if rel.is_view_dependent and draw(st.booleans()):
            step["viewpoint"] = draw(viewpoints())
    elif op is Op.RELATE_BETWEEN:
        step["inputs"] = _refs(draw, sets, 3)
    elif op in (Op.ARGMIN, Op.ARGMAX, Op.MIDDLE):
        metric = draw(st.sampled_from(list(Metric)))
        two = metric.is_distance and draw(st.booleans())
        n = 3 if metric.is_segment else 2 if two else 1
        step.update(inputs=_refs(draw, sets, n), metric=metric.value)
        if op is not Op.MIDDLE:
            step["k"] = draw(st.none() | st.integers(1, 4))
        if metric.is_seen_from:
            step["viewpoint"] = draw(viewpoints())
    elif op in (Op.UNION, Op.INTERSECT, Op.COALESCE):
        step["inputs"] = _refs(draw, sets, draw(st.integers(2, 3)))
    elif op is Op.DIFFERENCE:
        step["inputs"] = _refs(draw, sets, 2)
    else:  # support_closure, fall_if_removed, count, exists
        step["inputs"] = _refs(draw, sets, 1)
    return {k: v for k, v in step.items() if v is not None}


@st.composite
def viewpoints(draw: st.DrawFn) -> dict[str, list[float]]:
    """A valid viewpoint: eye and target at least MIN_VIEW_DISTANCE apart horizontally."""
    eye = [draw(COORDS) for _ in range(3)]
    target = [draw(COORDS) for _ in range(3)]
    if math.hypot(target[0] - eye[0], target[1] - eye[1]) < MIN_VIEW_DISTANCE:
        # A viewpoint needs a horizontal direction (the model refuses it).
        target[0] = eye[0] + 1.0
    return {"eye": eye, "target": target}


NON_SCENE_OPS = [op for op in Op if op is not Op.SCENE]
TOPOLOGICAL = {Op.RELATE, Op.RELATE_BETWEEN, Op.SUPPORT_CLOSURE, Op.FALL_IF_REMOVED}


@st.composite
def programs(draw: st.DrawFn, max_steps: int = 8) -> GraphQuery:
    """A valid random program: a scene step, then up to ``max_steps - 1`` steps."""
    steps: list[dict[str, Any]] = [{"op": "scene"}]
    sets = [0]
    topological = False
    for _ in range(draw(st.integers(1, max_steps - 1))):
        op = draw(st.sampled_from(NON_SCENE_OPS))
        if op is Op.SCENE or draw(st.integers(0, 9)) == 0:
            op = Op.SCENE
            steps.append({"op": "scene"})
        else:
            steps.append(draw(steps_for(op, sets)))
        topological |= op in TOPOLOGICAL
        if op not in (Op.COUNT, Op.EXISTS):
            sets.append(len(steps) - 1)
    types = [t for t in QueryType if not (topological and t is QueryType.INTRINSIC)]
    answer = draw(st.integers(0, len(steps) - 1) | st.just(len(steps) - 1))
    return GraphQuery.parse(
        {"query_type": draw(st.sampled_from(types)).value, "steps": steps, "answer_step": answer}
    )
