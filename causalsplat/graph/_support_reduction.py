"""An object rests on the top of a stack, not on everything the stack stands on.

The touch rule alone lets an object rest on everything whose top lies within the touch
tolerance of its bottom (a tolerance that has to be generous, for reconstructed boxes): a
cup on a 4 cm book on a table would rest on the book *and* on the table, and "if the book
is removed, the cup falls" would come out false. So the support pairs are reduced: when
``U`` rests on ``M`` and ``M`` rests (directly or through a chain) on ``L``, the pair
``U supported_by L`` is dropped, because ``M`` lies between them. Supporters that do not
rest on one another (a board across two stools) are all kept. This is the transitive
reduction of the supporters of each object; it needs no threshold, so it does not depend
on the scene's units. Support always goes up (the upper box's mid-height is higher), so
the support graph has no cycle.

Both the KD-tree path and the brute-force reference apply this same reduction to the same
set of support pairs, so they stay identical. ``EdgeConfig(reduce_support=False)`` keeps
every pair that passes the touch rule.
"""

from __future__ import annotations

from collections.abc import Sequence

from causalsplat.graph.config import EdgeConfig
from graph_store import Relation, RelationType


def reduce_supporters(relations: Sequence[Relation], config: EdgeConfig) -> list[Relation]:
    """``relations`` without the support pairs that an intermediate supporter explains."""
    if not config.reduce_support:
        return list(relations)
    below: dict[int, set[int]] = {}
    for r in relations:
        if r.type is RelationType.SUPPORTED_BY:
            below.setdefault(r.src, set()).add(r.dst)
    reach: dict[int, frozenset[int]] = {}

    def reachable(node: int) -> frozenset[int]:
        """Everything ``node`` rests on, directly or through a chain (memoised DFS)."""
        if node in reach:
            return reach[node]
        found: set[int] = set()
        stack = list(below.get(node, ()))
        while stack:
            nxt = stack.pop()
            if nxt not in found:
                found.add(nxt)
                stack.extend(below.get(nxt, ()))
        reach[node] = frozenset(found)
        return reach[node]

    hidden: set[tuple[int, int]] = set()
    for upper, direct in below.items():
        if len(direct) < 2:
            continue
        for middle in direct:
            for lower in reachable(middle) & direct:
                hidden.add((upper, lower))
    out = []
    for r in relations:
        if r.type is RelationType.SUPPORTED_BY and (r.src, r.dst) in hidden:
            continue
        if r.type is RelationType.SUPPORTS and (r.dst, r.src) in hidden:
            continue
        out.append(r)
    return out
