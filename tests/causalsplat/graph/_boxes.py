"""Small helpers to write test scenes as boxes."""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from graph_store import Entity, Relation


def box(
    entity_id: int,
    lo: Sequence[float],
    hi: Sequence[float],
    category: str = "object",
    centroid: Sequence[float] | None = None,
) -> Entity:
    """An entity with box ``lo..hi``; the centroid defaults to the box centre."""
    centre = centroid if centroid is not None else [(a + b) / 2 for a, b in zip(lo, hi)]
    return Entity(entity_id, category, tuple(centre), tuple(lo), tuple(hi))


def cube(entity_id: int, centre: Sequence[float], side: float = 1.0, **kw: object) -> Entity:
    half = side / 2
    return box(entity_id, [c - half for c in centre], [c + half for c in centre], **kw)  # type: ignore[arg-type]


def triples(relations: Iterable[Relation]) -> set[tuple[int, str, int]]:
    return {(r.src, r.type.value, r.dst) for r in relations}


def find(relations: Iterable[Relation], src: int, kind: str, dst: int) -> dict[str, float]:
    """The evidence of one relation (``KeyError`` when it is missing)."""
    for r in relations:
        if (r.src, r.type.value, r.dst) == (src, kind, dst):
            return r.evidence_dict
    raise KeyError((src, kind, dst))
