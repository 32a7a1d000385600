"""The ground-truth support structure of a synthetic room: closures, depths, what falls.

Support follows the rule of DESIGN §6 ``fall_if_removed``: an entity falls when every one of
its supporters is removed or has fallen (so an object on two supporters survives the loss of
one); the floor and the walls never fall.
"""

from __future__ import annotations

from collections.abc import Iterable
from functools import cache

from causalsplat.synth._layout import RoomLayout
from causalsplat.synth.vocab import Kind


def fall_if_removed(layout: RoomLayout, removed: Iterable[int]) -> frozenset[int]:
    """Entities that fall when ``removed`` are taken away (the removed ones excluded)."""
    gone = set(removed)
    start = frozenset(gone)
    changed = True
    while changed:
        changed = False
        for obj in layout.objects:
            if obj.id in gone or obj.kind is Kind.STRUCTURE or not obj.supporters:
                continue
            if all(s in gone for s in obj.supporters):
                gone.add(obj.id)
                changed = True
    return frozenset(gone - start)


def support_closure(layout: RoomLayout, roots: Iterable[int]) -> frozenset[int]:
    """Everything transitively resting on ``roots`` (roots excluded)."""
    start = frozenset(roots)
    seen: set[int] = set()
    frontier = list(start)
    while frontier:
        current = frontier.pop()
        for child in layout.children(current):
            if child not in seen and child not in start:
                seen.add(child)
                frontier.append(child)
    return frozenset(seen)


def support_depth(layout: RoomLayout, entity_id: int) -> int:
    """Length of the longest support chain from ``entity_id`` down to the floor.

    0 for structure, 1 for furniture on the floor, 2 for a book on a table, and so on.
    """

    @cache
    def depth(i: int) -> int:
        supporters = layout.get(i).supporters
        return 0 if not supporters else 1 + max(depth(s) for s in supporters)

    return depth(entity_id)
