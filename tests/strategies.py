"""Hypothesis strategies and generators of scene graphs shared by the test suites."""

from __future__ import annotations

import numpy as np
from hypothesis import strategies as st

from graph_store import (
    STORED_RELATION_TYPES,
    Attribute,
    AttributeSource,
    Entity,
    MaskRecord,
    Relation,
    SceneGraph,
    SceneMeta,
    View,
)

# Any Unicode except NUL and lone surrogates (which no database text column can hold).
text_chars = st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00")
names = st.text(text_chars, min_size=1, max_size=24)
scene_ids = st.text(st.characters(blacklist_categories=("Cs", "Cc")), min_size=1, max_size=24)
coords = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False, allow_infinity=False)


@st.composite
def entities(draw: st.DrawFn, entity_id: int) -> Entity:
    lo = [draw(coords) for _ in range(3)]
    hi = [draw(coords) for _ in range(3)]
    lo, hi = [min(a, b) for a, b in zip(lo, hi)], [max(a, b) for a, b in zip(lo, hi)]
    attrs = draw(
        st.lists(
            st.builds(Attribute, names, names, st.sampled_from(AttributeSource)),
            max_size=3,
            unique_by=lambda a: (a.key, a.value),
        )
    )
    return Entity(
        id=entity_id,
        category=draw(names),
        centroid=tuple(draw(coords) for _ in range(3)),
        bbox_min=tuple(lo),
        bbox_max=tuple(hi),
        external_id=draw(
            st.none() | st.just(f"ext-{entity_id}") | names.map(lambda s: f"{entity_id}:{s}")
        ),
        caption=draw(st.none() | st.text(text_chars, max_size=40)),
        point_count=draw(st.integers(0, 10**9)),
        confidence=draw(st.none() | st.floats(0.0, 1.0)),
        attributes=tuple(attrs),
    )


@st.composite
def scene_graphs(
    draw: st.DrawFn, max_entities: int = 12, scene_id: str | None = None
) -> SceneGraph:
    n = draw(st.integers(0, max_entities))
    ids = draw(st.lists(st.integers(0, 10**6), min_size=n, max_size=n, unique=True))
    ents = [draw(entities(i)) for i in ids]
    rels: list[Relation] = []
    if len(ids) >= 2:
        triples = draw(
            st.lists(
                st.tuples(
                    st.sampled_from(ids),
                    st.sampled_from(ids),
                    st.sampled_from(STORED_RELATION_TYPES),
                ),
                max_size=3 * n,
                unique=True,
            )
        )
        for src, dst, rel in triples:
            if src != dst:
                evidence = draw(st.dictionaries(names, coords, max_size=3))
                rels.append(Relation(src, dst, rel, evidence))
    views = [
        View(i, f"frame{i:05d}", draw(st.integers(1, 4096)), draw(st.integers(1, 4096)))
        for i in range(draw(st.integers(0, 3)))
    ]
    masks = []
    for v in views:
        for k in range(draw(st.integers(0, 3))):
            masks.append(
                MaskRecord(
                    v.id, k, draw(st.none() | st.sampled_from(ids)) if ids else None,
                    draw(st.none() | names), draw(st.none() | st.floats(0, 1)),
                )
            )  # fmt: skip
    meta = SceneMeta(
        scene_id=scene_id or draw(scene_ids),
        name=draw(st.none() | st.text(text_chars, max_size=20)),
        units=draw(st.sampled_from(["m", "mm", "km"])),
        up_axis=draw(st.sampled_from(["x", "y", "z"])),
        source=draw(st.sampled_from(["objects", "build", "rdf"])),
        config_hash=draw(st.none() | st.text("0123456789abcdef", min_size=8, max_size=64)),
        provenance=draw(st.dictionaries(names, st.text(text_chars, max_size=20), max_size=3)),
    )
    return SceneGraph(meta, tuple(ents), tuple(rels), tuple(views), tuple(masks))


def random_scene(
    scene_id: str, n_entities: int, n_relations: int, *, seed: int = 0, evidence: bool = True
) -> SceneGraph:
    """A large random scene graph (numpy-generated, for size tests and benchmarks)."""
    rng = np.random.default_rng(seed)
    centers = rng.uniform(-20, 20, size=(n_entities, 3))
    half = rng.uniform(0.05, 1.0, size=(n_entities, 3))
    cats = ["chair", "table", "cup", "book", "sink", "towel", "bed", "lamp", "shelf", "plant"]
    ents = tuple(
        Entity(
            id=i,
            category=cats[i % len(cats)],
            centroid=tuple(centers[i]),
            bbox_min=tuple(centers[i] - half[i]),
            bbox_max=tuple(centers[i] + half[i]),
            external_id=str(i),
            point_count=int(rng.integers(10, 5000)),
            attributes=(Attribute("color", ["red", "blue", "white"][i % 3]),),
        )
        for i in range(n_entities)
    )
    pairs: set[tuple[int, int, int]] = set()
    types = STORED_RELATION_TYPES
    while len(pairs) < n_relations:
        k = n_relations - len(pairs)
        src = rng.integers(0, n_entities, size=k)
        dst = rng.integers(0, n_entities, size=k)
        typ = rng.integers(0, len(types), size=k)
        pairs.update((int(a), int(b), int(t)) for a, b, t in zip(src, dst, typ) if a != b)
    ordered = sorted(pairs)[:n_relations]
    rels = tuple(
        Relation(a, b, types[t], {"distance": float(abs(a - b)) / n_entities} if evidence else {})
        for a, b, t in ordered
    )
    return SceneGraph(SceneMeta(scene_id, source="build"), ents, rels)
