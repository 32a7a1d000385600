"""Stage 3 of the offline reasoner: the decision (target ids and the program's last steps).

* A referring expression names one entity: when several candidates are left, the one
  closest to the anchor of the last relation is taken (horizontally for ``above`` and
  ``below``: the one most directly over or under it), or, with no anchor, the largest;
  the explanation says so.
* A set question keeps every candidate; ``how many`` ends in ``count``, ``is there`` in
  ``exists``.
* A counterfactual removes the named entities and asks what falls (``fall_if_removed``),
  or what rests on them transitively (``support_closure``) for "everything stacked on".
* An action request ("where can I wash my hands?") selects the entities affording the
  matched affordances (stored ``affordance`` attributes, or the lexicon's affordances of
  the scene's categories when the scene stores none), then applies the target's relations.

The query type (stage 1's classification) follows from what the program does:
``counterfactual``; ``affordance`` (an action with a relation to an anchor);
``commonsense`` (an action alone); ``spatial`` (any relation or viewpoint); else
``intrinsic`` (categories, attributes and modifiers only: no topology).
"""

from __future__ import annotations

from dataclasses import dataclass

from causalsplat.reason._builder import SCENE, ProgramBuilder
from causalsplat.reason.affordance import match_affordances
from causalsplat.reason.embed import TextEmbedder
from causalsplat.reason.errors import InstructionError
from causalsplat.reason.lexicon import Lexicon
from causalsplat.reason.parse import Instruction
from causalsplat.reason.topology import SUM_METRIC, Planner
from queries import GraphQuery


@dataclass(frozen=True, slots=True)
class Decision:
    """The program stages 1-3 chose and the notes explaining it."""

    program: GraphQuery
    notes: tuple[str, ...]


#: How the explanation names what a tie-break metric measures to (other: "both anchors").
_CLOSEST_TO = {"distance": "the anchor", "horizontal_distance": "the anchor, horizontally"}


def decide(
    builder: ProgramBuilder,
    instruction: Instruction,
    lexicon: Lexicon,
    embedder: TextEmbedder | None = None,
) -> Decision:
    """Plan and decide (module docstring); raises :class:`InstructionError` when the
    instruction names nothing the scene holds."""
    planner = Planner(builder, instruction)
    ins = instruction
    if ins.kind == "counterfactual":
        answer, qtype = _counterfactual(builder, planner, ins), "counterfactual"
    elif ins.kind == "action":
        answer, qtype = _action(builder, planner, ins, lexicon, embedder)
    else:
        answer, qtype = _referring(builder, planner, ins)
    return Decision(builder.program(answer, qtype), tuple(builder.notes))


def _counterfactual(b: ProgramBuilder, planner: Planner, ins: Instruction) -> int:
    removed = []
    for np in ins.removed:
        planned = planner.plan(np, singular=False, role="removed")
        if planned is not None:
            removed.append(planned.step)
    if not removed:
        raise InstructionError(
            f"{ins.text!r}: nothing it says is removed is in scene {b.ctx.scene_id!r}"
        )
    what = b.union(removed)
    b.note(f"removed: {', '.join(np.text for np in ins.removed)}")
    return b.add("support_closure" if ins.closure else "fall_if_removed", what)


def _action(
    b: ProgramBuilder,
    planner: Planner,
    ins: Instruction,
    lexicon: Lexicon,
    embedder: TextEmbedder | None,
) -> tuple[int, str]:
    ctx = b.ctx
    key = ctx.config.affordance_key
    stored = ctx.attribute_values(key)
    if stored:
        candidates: dict[str, list[str]] = {v: [] for v in stored}
    else:
        candidates = {}
        for category in ctx.categories:
            for phrase in lexicon.affordances(category):
                candidates.setdefault(phrase, []).append(category)
    match = match_affordances(ins.action, list(candidates), lexicon, embedder=embedder)
    if not match.phrases:
        raise InstructionError(
            f"{ins.text!r}: no affordance of scene {ctx.scene_id!r} fits {' '.join(ins.action)!r}"
        )
    b.note(f"affordance: {' / '.join(match.phrases)} ({match.method} match)")
    if stored:
        parts = [b.add("filter_affordance", SCENE, value=p) for p in match.phrases]
    else:
        cats = sorted({c for p in match.phrases for c in candidates[p]})
        b.note(f"from the lexicon, afforded by: {', '.join(cats)}")
        parts = [b.add("filter_category", SCENE, value=c) for c in cats]
    step = b.union(parts)
    target = ins.target
    related = False
    if target is not None:
        for constraint in target.constraints:
            out = planner.relation(step, constraint, singular=False, selectors=False)
            if out is not None:
                step, related = out.step, True
    return step, ("affordance" if related else "commonsense")


def _referring(b: ProgramBuilder, planner: Planner, ins: Instruction) -> tuple[int, str]:
    target = ins.target
    assert target is not None
    singular = ins.kind == "refer"
    planned = planner.plan(target, singular=singular)
    if planned is None:
        raise InstructionError(
            f"{ins.text!r}: names nothing in scene {b.ctx.scene_id!r}"
            f" (categories: {', '.join(b.ctx.categories[:12])}"
            f"{', ...' if len(b.ctx.categories) > 12 else ''})"
        )
    step = planned.step
    if singular and b.size(step) > 1:
        n = b.size(step)
        if planned.anchor is not None:
            metric = "horizontal_distance" if planned.vertical else "distance"
            if planned.between and SUM_METRIC is not None:
                metric = SUM_METRIC
            step = b.add("argmin", step, planned.anchor, metric=metric)
            what = _CLOSEST_TO.get(metric, "both anchors")
            b.note(f"{n} candidates fit; took the one closest to {what}")
        else:
            step = b.add("argmax", step, metric="volume")
            b.note(f"{n} candidates fit; took the largest")
    if ins.kind == "count":
        step = b.add("count", step)
    elif ins.kind == "exists":
        step = b.add("exists", step)
    topological = bool(target.constraints) or ins.viewpoint is not None
    return step, ("spatial" if topological else "intrinsic")
