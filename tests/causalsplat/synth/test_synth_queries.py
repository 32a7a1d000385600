"""Generated queries: every answer re-derived from the layout by an independent resolver."""

from __future__ import annotations

import re
from collections.abc import Iterator

import numpy as np
import pytest

from causalsplat.synth import SynthConfig
from causalsplat.synth._layout import RoomLayout, SynthObject, generate_layout
from causalsplat.synth._queries import GeneratedQuery, generate_queries
from causalsplat.synth.generate import stream
from causalsplat.synth.vocab import AFFORDANCE_PHRASES, COLORS, COMMONSENSE_QUESTIONS, Kind

SIZES = ("tiny", "small", "medium")
SEEDS = range(8)
TYPES = {"spatial", "commonsense", "affordance", "counterfactual"}


def scene(size: str, seed: int) -> tuple[RoomLayout, tuple[GeneratedQuery, ...]]:
    cfg = SynthConfig.preset(size, seed=seed)
    layout = generate_layout(cfg, stream(seed, "layout"))
    return layout, generate_queries(layout, cfg.max_queries_per_type, stream(seed, "queries"))


def things(layout: RoomLayout) -> list[SynthObject]:
    return [o for o in layout.objects if o.kind is not Kind.STRUCTURE]


def resolve(layout: RoomLayout, phrase: str) -> set[int]:
    """Entities a noun phrase names: 'the cup', 'the red cup', 'the cup on <phrase>'."""
    m = re.fullmatch(r"the (\w+) on (.+)", phrase)
    if m:
        bases = resolve(layout, m.group(2))
        return {
            o.id for o in things(layout) if o.category == m.group(1) and set(o.supporters) & bases
        }
    words = phrase.split(" ")
    assert words[0] == "the", phrase
    if len(words) == 3 and words[1] in COLORS:
        return {o.id for o in things(layout) if (o.color, o.category) == (words[1], words[2])}
    assert len(words) == 2, phrase
    return {o.id for o in things(layout) if o.category == words[1]}


def one(layout: RoomLayout, phrase: str) -> SynthObject:
    found = resolve(layout, phrase)
    assert len(found) == 1, (phrase, found)
    return layout.get(found.pop())


def support_paths(layout: RoomLayout, entity: int) -> Iterator[list[int]]:
    """Every chain of supporters from ``entity`` down to the floor."""
    obj = layout.get(entity)
    if not obj.supporters:
        yield [entity]
    for s in obj.supporters:
        for path in support_paths(layout, s):
            yield [entity, *path]


def falls(layout: RoomLayout, removed: set[int]) -> set[int]:
    """Entities whose every support path passes through a removed entity."""
    return {
        o.id
        for o in things(layout)
        if o.id not in removed and all(set(p) & removed for p in support_paths(layout, o.id))
    }


def dist(a: SynthObject, b: SynthObject) -> float:
    return float(np.linalg.norm(np.asarray(a.center) - np.asarray(b.center)))


def check(layout: RoomLayout, q: GeneratedQuery) -> None:
    targets = set(q.targets)
    text = q.text
    if q.type == "counterfactual":
        m = re.fullmatch(r"if (.+?)(?: and (.+?))? (?:is|are) removed, what falls\?", text)
        assert m, text
        removed = {one(layout, g).id for g in m.groups() if g}
        assert targets == falls(layout, removed), text
    elif q.type == "commonsense":
        [aff] = [a for a, t in COMMONSENSE_QUESTIONS.items() if t == text]
        assert targets == {o.id for o in things(layout) if aff in o.affordances}
    elif q.type == "affordance":
        [(aff, phrase)] = [
            (a, p) for a, p in AFFORDANCE_PHRASES.items() if text.startswith(p + " ")
        ]
        anchor = one(layout, text.removeprefix(phrase + " near "))

        def half(o: SynthObject) -> float:
            return 0.5 * float(np.hypot(o.size[0], o.size[1]))

        near = {
            o.id
            for o in things(layout)
            if aff in o.affordances
            and o.id != anchor.id
            and dist(o, anchor) < 1.5 * (half(o) + half(anchor))
        }
        assert targets == near, text
    elif q.type == "intrinsic":
        assert targets == {one(layout, text).id}
    elif m := re.fullmatch(r"what is on (.+)\?", text):
        base = one(layout, m.group(1))
        assert targets == {o.id for o in layout.objects if base.id in o.supporters}
    elif m := re.fullmatch(r"what is (.+) resting on\?", text):
        assert targets == set(one(layout, m.group(1)).supporters)
    elif m := re.fullmatch(r"the (\w+) (closest to|farthest from) (.+)", text):
        anchor = one(layout, m.group(3))
        members = [o for o in things(layout) if o.category == m.group(1)]
        ranked = sorted(members, key=lambda o: dist(o, anchor), reverse=m.group(2) != "closest to")
        assert len(members) >= 2 and targets == {ranked[0].id}
        assert abs(dist(ranked[1], anchor) - dist(ranked[0], anchor)) >= 0.3
    else:
        assert re.fullmatch(r"the \w+ on .+", text), text
        assert targets == {one(layout, text).id}


@pytest.mark.parametrize("size", SIZES)
@pytest.mark.parametrize("seed", SEEDS)
def test_every_query_is_answered_by_the_layout(size: str, seed: int) -> None:
    layout, queries = scene(size, seed)
    assert [q.id for q in queries] == [f"q{k:03d}" for k in range(len(queries))]
    assert len({q.text for q in queries}) == len(queries)
    valid = {o.id for o in things(layout)}
    for q in queries:
        assert q.targets and set(q.targets) <= valid, q
        assert list(q.targets) == sorted(set(q.targets))
        check(layout, q)


@pytest.mark.parametrize("size", SIZES)
def test_all_four_levels_and_the_two_supporter_case(size: str) -> None:
    for seed in SEEDS:
        layout, queries = scene(size, seed)
        assert {q.type for q in queries} >= TYPES, (size, seed)
        pair = [q for q in queries if q.type == "counterfactual" and " and " in q.text]
        boards = {o.id for o in layout.objects if len(o.supporters) == 2}
        assert any(set(q.targets) & boards for q in pair), (size, seed)


def test_removing_one_of_two_supporters_drops_nothing_it_shares() -> None:
    layout, queries = scene("small", 1)
    for q in queries:
        if q.type != "counterfactual" or " and " in q.text:
            continue
        removed = one(layout, q.text.removeprefix("if ").removesuffix(" is removed, what falls?"))
        for t in q.targets:  # a fallen entity has lost every one of its supporters
            sups = set(layout.get(t).supporters)
            assert sups <= set(q.targets) | {removed.id}


def test_queries_are_deterministic() -> None:
    assert scene("small", 2)[1] == scene("small", 2)[1]
    assert scene("small", 2)[1] != scene("small", 3)[1]
