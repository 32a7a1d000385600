"""Queries of all four reasoning levels, answered from the generator's own ground truth.

A query is emitted only when its answer is unambiguous: every entity it names has a unique
referring expression ("the table", "the red cup", "the cup on the book"), superlatives need a
clear margin under both centroid and box distance, and "near" needs every candidate to be at
least 15 % away from the proximity threshold of DESIGN §7.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np

from causalsplat.synth._layout import RoomLayout, SynthObject
from causalsplat.synth.support import fall_if_removed
from causalsplat.synth.vocab import AFFORDANCE_PHRASES, COMMONSENSE_QUESTIONS, Kind

#: DESIGN §7 proximity: centroid distance < NEAR_FACTOR x (sum of footprint half-diagonals).
NEAR_FACTOR = 1.5
_NEAR_MARGIN = 0.15

#: A candidate query: its text and its target entity ids.
_Candidate = tuple[str, tuple[int, ...]]


@dataclass(frozen=True, slots=True)
class GeneratedQuery:
    """One query of the queries file (DESIGN §9).

    Attributes:
        id: query id, unique in the scene.
        text: the instruction, in English.
        type: ``spatial``, ``commonsense``, ``affordance``, ``counterfactual`` or ``intrinsic``.
        targets: the whole correct answer, as entity (external) ids, ascending.
    """

    id: str
    text: str
    type: str
    targets: tuple[int, ...]


def centroid_distance(a: SynthObject, b: SynthObject) -> float:
    return float(np.linalg.norm(np.asarray(a.center) - np.asarray(b.center)))


def box_distance(a: SynthObject, b: SynthObject) -> float:
    """Gap between two boxes (0 when they touch or overlap), metres."""
    gap = np.maximum(0.0, np.maximum(a.lo - b.hi, b.lo - a.hi))
    return float(np.linalg.norm(gap))


def near_ratio(a: SynthObject, b: SynthObject, *, horizontal: bool = False) -> float:
    """Centroid distance over the DESIGN §7 near threshold (< 1 means near)."""
    half = 0.5 * (np.hypot(a.size[0], a.size[1]) + np.hypot(b.size[0], b.size[1]))
    delta = np.asarray(a.center) - np.asarray(b.center)
    dist = np.hypot(delta[0], delta[1]) if horizontal else np.linalg.norm(delta)
    return float(dist / (NEAR_FACTOR * half))


class _Referrer:
    """Unique referring expressions for the entities of a layout."""

    def __init__(self, layout: RoomLayout) -> None:
        self.layout = layout
        self.things = [o for o in layout.objects if o.kind is not Kind.STRUCTURE]
        self.per_cat = Counter(o.category for o in self.things)
        self.per_cat_color = Counter((o.category, o.color) for o in self.things)

    def simple(self, obj: SynthObject) -> str | None:
        if obj.kind is Kind.STRUCTURE:
            return None
        if self.per_cat[obj.category] == 1:
            return f"the {obj.category}"
        if self.per_cat_color[(obj.category, obj.color)] == 1:
            return f"the {obj.color} {obj.category}"
        return None

    def on_phrase(self, obj: SynthObject) -> str | None:
        """ "the cup on the book": obj is the only one of its category on a nameable supporter."""
        if len(obj.supporters) != 1:
            return None
        base = self.layout.get(obj.supporters[0])
        base_ref = self.simple(base)
        same = [
            c for c in self.layout.children(base.id) if self.layout.get(c).category == obj.category
        ]
        if base_ref is None or same != [obj.id]:
            return None
        return f"the {obj.category} on {base_ref}"

    def ref(self, obj: SynthObject) -> str | None:
        return self.simple(obj) or self.on_phrase(obj)


def _clear_argmin(values: list[tuple[float, float, int]], rel: float, abs_m: float) -> int | None:
    """The id minimising both metrics, when it wins each by a clear margin."""
    by_c = sorted(values)
    by_b = sorted(values, key=lambda v: (v[1], v[0]))
    if by_c[0][2] != by_b[0][2]:
        return None
    if by_c[1][0] - by_c[0][0] < max(abs_m, rel * by_c[0][0]):
        return None
    if by_b[1][1] - by_b[0][1] < abs_m / 3:
        return None
    return by_c[0][2]


def _spatial(layout: RoomLayout, r: _Referrer) -> list[list[_Candidate]]:
    on: list[_Candidate] = []
    closest: list[_Candidate] = []
    farthest: list[_Candidate] = []
    what_on: list[_Candidate] = []
    resting: list[_Candidate] = []
    for obj in r.things:
        phrase = r.on_phrase(obj)
        if phrase and r.per_cat[obj.category] > 1:
            on.append((phrase, (obj.id,)))
        kids = layout.children(obj.id)
        name = r.simple(obj)
        if name and kids:
            what_on.append((f"what is on {name}?", tuple(sorted(kids))))
        if name and obj.supporters and obj.supporters != (0,):
            resting.append((f"what is {name} resting on?", tuple(sorted(obj.supporters))))
    for cat, count in sorted(r.per_cat.items()):
        if count < 2:
            continue
        members = [o for o in r.things if o.category == cat]
        for anchor in r.things:
            a_ref = r.simple(anchor)
            if anchor.category == cat or a_ref is None:
                continue
            vals = [(centroid_distance(m, anchor), box_distance(m, anchor), m.id) for m in members]
            best = _clear_argmin(vals, 0.25, 0.3)
            if best is not None:
                closest.append((f"the {cat} closest to {a_ref}", (best,)))
            far = _clear_argmin([(-c, -b, i) for c, b, i in vals], 0.0, 0.3)
            if far is not None:
                farthest.append((f"the {cat} farthest from {a_ref}", (far,)))
    return [on, closest, what_on, resting, farthest]


def _commonsense(r: _Referrer) -> list[list[_Candidate]]:
    out: list[_Candidate] = []
    for affordance, question in COMMONSENSE_QUESTIONS.items():
        holders = tuple(o.id for o in r.things if affordance in o.affordances)
        if holders:
            out.append((question, holders))
    return [out]


def _affordance(r: _Referrer) -> list[list[_Candidate]]:
    out: list[_Candidate] = []
    for affordance, phrase in AFFORDANCE_PHRASES.items():
        holders = [o for o in r.things if affordance in o.affordances]
        for anchor in r.things:
            a_ref = r.simple(anchor)
            if a_ref is None or anchor.kind is not Kind.FURNITURE:
                continue
            cands = [o for o in holders if o.id != anchor.id]
            ratios = [
                (near_ratio(o, anchor), near_ratio(o, anchor, horizontal=True)) for o in cands
            ]
            clear = all(
                abs(a - 1) >= _NEAR_MARGIN and abs(b - 1) >= _NEAR_MARGIN and (a < 1) == (b < 1)
                for a, b in ratios
            )
            near = tuple(o.id for o, (a, _) in zip(cands, ratios, strict=True) if a < 1)
            if clear and near:
                out.append((f"{phrase} near {a_ref}", near))
    return [out]


def _counterfactual(layout: RoomLayout, r: _Referrer) -> list[list[_Candidate]]:
    singles: list[_Candidate] = []
    pairs: list[_Candidate] = []
    for obj in r.things:
        name = r.ref(obj)
        fallen = fall_if_removed(layout, [obj.id])
        if name and fallen:
            singles.append((f"if {name} is removed, what falls?", tuple(sorted(fallen))))
        if len(obj.supporters) == 2 and 0 not in obj.supporters:
            a, b = (layout.get(s) for s in obj.supporters)
            ra, rb = r.ref(a), r.ref(b)
            if ra and rb:
                fallen = fall_if_removed(layout, obj.supporters)
                text = f"if {ra} and {rb} are removed, what falls?"
                pairs.append((text, tuple(sorted(fallen))))
    return [pairs, singles]


def _intrinsic(r: _Referrer) -> list[list[_Candidate]]:
    out: list[_Candidate] = []
    for obj in r.things:
        name = r.simple(obj)
        if name and r.per_cat[obj.category] > 1:
            out.append((name, (obj.id,)))
    return [out]


def _pick(groups: list[list[_Candidate]], k: int, rng: np.random.Generator) -> list[_Candidate]:
    """Up to ``k`` distinct queries, round-robin over the templates (first group first)."""
    shuffled = [[g[i] for i in rng.permutation(len(g))] for g in groups]
    out: list[_Candidate] = []
    seen: set[str] = set()
    while len(out) < k and any(shuffled):
        for group in shuffled:
            while group and len(out) < k:
                text, targets = group.pop(0)
                if text not in seen:
                    seen.add(text)
                    out.append((text, targets))
                    break
    return out


def generate_queries(
    layout: RoomLayout, max_per_type: int, rng: np.random.Generator
) -> tuple[GeneratedQuery, ...]:
    """Queries of every reasoning level (module docstring), ids ``q000``, ``q001``, ..."""
    r = _Referrer(layout)
    makers: list[tuple[str, Callable[[], Iterable[list[_Candidate]]]]] = [
        ("spatial", lambda: _spatial(layout, r)),
        ("commonsense", lambda: _commonsense(r)),
        ("affordance", lambda: _affordance(r)),
        ("counterfactual", lambda: _counterfactual(layout, r)),
        ("intrinsic", lambda: _intrinsic(r)),
    ]
    queries: list[GeneratedQuery] = []
    for qtype, make in makers:
        for text, targets in _pick(list(make()), max_per_type, rng):
            qid = f"q{len(queries):03d}"
            queries.append(GeneratedQuery(qid, text, qtype, tuple(sorted(targets))))
    return tuple(queries)
