"""Stage 3 of the offline reasoner: planning and the decision (the program's steps).

Reads stage 2's :class:`~causalsplat.reason.ground.Grounded` instruction only.

* A referring expression names one entity: the grounded categories, narrowed by the
  target's relations (:class:`~causalsplat.reason.topology.Planner`); when several
  candidates are left, the one closest to the anchor of the last relation is taken
  (horizontally for ``above`` and ``below``: the one most directly over or under it), or,
  with no anchor, the one nearest in colour to the phrase's colour word (by the stored
  colours, when it names one), else the largest; the explanation says so.
* A set question keeps every candidate; ``how many`` ends in ``count``, ``is there`` in
  ``exists``.
* A counterfactual removes the grounded entities and asks what falls
  (``fall_if_removed``), or what rests on them transitively (``support_closure``) for
  "everything stacked on".
* A need ("where can I wash my hands?") selects every entity of the categories grounded
  for it, then applies the relations whose anchors the sentence names outright ("the
  thing to dry them next to the sink"): a relation that leaves none of the best
  categories is tried on the top three, then dropped (the explanation says so). A
  definite singular target with a relation ("the thing ... next to the sink") takes the
  one closest to the anchor.
* When grounding finds nothing that fits, the program selects nothing
  (``difference(scene, scene)``) and the explanation lists the closest candidates:
  a well-formed sentence is never an error.

The query type (stage 1's classification) follows from what the program does:
``counterfactual``; ``affordance`` (a need with a relation to an anchor);
``commonsense`` (a need alone); ``spatial`` (any relation or viewpoint); else
``intrinsic`` (categories, attributes and modifiers only: no topology).
"""

from __future__ import annotations

from dataclasses import dataclass

from causalsplat.reason._builder import SCENE, ProgramBuilder
from causalsplat.reason.ground import Grounded, Grounding, is_named
from causalsplat.reason.parse import Instruction
from causalsplat.reason.topology import Planned, Planner
from queries import GraphQuery, Metric, Op


@dataclass(frozen=True, slots=True)
class Decision:
    """The program stages 1-3 chose and the notes explaining it."""

    program: GraphQuery
    notes: tuple[str, ...]


#: How the explanation names what a tie-break metric measures to (other: "both anchors").
_CLOSEST_TO = {
    Metric.DISTANCE: "the anchor",
    Metric.HORIZONTAL_DISTANCE: "the anchor, horizontally",
    Metric.BOX_DISTANCE: "the anchor's surface",
    Metric.END_DISTANCE: "an end of the anchor",
    Metric.CORNER_DISTANCE: "a corner of the anchor",
}


def decide(builder: ProgramBuilder, grounded: Grounded) -> Decision:
    """Plan and decide (module docstring); never raises on a grounded instruction."""
    ins = grounded.instruction
    planner = Planner(builder, ins, grounded.anchor_categories)
    if ins.kind == "counterfactual":
        answer, qtype = _counterfactual(builder, planner, grounded), "counterfactual"
    elif ins.kind == "action":
        answer, qtype = _need(builder, planner, grounded)
    else:
        answer, qtype = _referring(builder, planner, grounded)
    return Decision(builder.program(answer, qtype), tuple(builder.notes))


def _nothing(b: ProgramBuilder) -> int:
    """A step that selects nothing (the answer when nothing here fits)."""
    return b.add(Op.DIFFERENCE, SCENE, SCENE)


def _counterfactual(b: ProgramBuilder, planner: Planner, grounded: Grounded) -> int:
    ins = grounded.instruction
    removed = []
    for np, g in zip(ins.removed, grounded.removed, strict=True):
        if not g.fits:
            b.note(g.describe())
            continue
        if g.how != "named":
            b.note(g.describe())
        planned = planner.plan(np, singular=False, role="removed", categories=g.chosen)
        if planned is not None:
            removed.append(planned.step)
    if not removed:
        b.note("nothing it says is removed is in the scene; nothing falls")
        return b.add(Op.FALL_IF_REMOVED, _nothing(b))
    what = b.union(removed)
    b.note(f"removed: {', '.join(np.text for np in ins.removed)}")
    return b.add(Op.SUPPORT_CLOSURE if ins.closure else Op.FALL_IF_REMOVED, what)


def _need(b: ProgramBuilder, planner: Planner, grounded: Grounded) -> tuple[int, str]:
    g = grounded.target
    assert g is not None
    b.note(g.describe())
    if not g.fits:
        return _nothing(b), "commonsense"
    if g.affordances:
        step = b.union([b.add(Op.FILTER_AFFORDANCE, SCENE, value=p) for p, _ in g.affordances])
    else:
        step = b.union([b.add(Op.FILTER_CATEGORY, SCENE, value=c) for c in g.chosen])
    target = grounded.instruction.target
    related = False
    if target is not None:
        wider = [c.category for c in g.candidates[:3] if c.score >= g.candidates[0].score * 0.5]
        for constraint in target.constraints:
            if not all(is_named(a) for a in constraint.anchors):
                b.note(f"relation {constraint.kind!r} not used: its anchor is not named")
                continue
            out = planner.relation(step, constraint, singular=False, selectors=False)
            if out is None:
                continue
            if b.size(out.step) == 0 and not g.affordances and len(wider) > len(g.chosen):
                base = b.union([b.add(Op.FILTER_CATEGORY, SCENE, value=c) for c in wider])
                retry = planner.relation(base, constraint, singular=False, selectors=False)
                if retry is not None and b.size(retry.step) > 0:
                    b.note(f"none of {', '.join(g.chosen)} fits the relation; tried the top 3")
                    out = retry
            if b.size(out.step) == 0:
                if _definite(grounded.instruction) and out.anchor not in (None, step):
                    b.note(f"nothing fits the relation {constraint.kind!r}; took the closest")
                    step = b.add(Op.ARGMIN, step, out.anchor, metric=b.distance_to(out.anchor))
                    related = True
                else:
                    b.note(f"nothing fits the relation {constraint.kind!r}; it was not used")
                continue
            step, related = _closest_if_singular(b, grounded.instruction, out), True
    return step, ("affordance" if related else "commonsense")


def _definite(ins: Instruction) -> bool:
    """The need's target is one definite thing ("the thing", "that one")."""
    target, tokens = ins.target, ins.main_tokens
    mention = None if target is None else target.mention
    return (
        mention is not None
        and not mention.plural
        and 0 < mention.start <= len(tokens)
        and tokens[mention.start - 1] in ("the", "this", "that")
    )


def _closest_if_singular(b: ProgramBuilder, ins: Instruction, out: Planned) -> int:
    """ "hand me the thing ... next to the sink" (definite, singular): one entity, the
    closest to the anchor; "something to sit on near the table": every one that fits."""
    if _definite(ins) and out.anchor is not None and b.size(out.step) > 1:
        b.note(f"{b.size(out.step)} fit; took the one closest to the anchor")
        return b.add(Op.ARGMIN, out.step, out.anchor, metric=b.distance_to(out.anchor))
    return out.step


def _referring(b: ProgramBuilder, planner: Planner, grounded: Grounded) -> tuple[int, str]:
    ins = grounded.instruction
    target = ins.target
    assert target is not None
    singular = ins.kind == "refer"
    g: Grounding | None = grounded.target
    if g is not None and g.how != "named":
        b.note(g.describe())
    if g is not None and not g.fits:
        return _finish(b, ins, _nothing(b)), "intrinsic"
    planned = planner.plan(target, singular=singular, categories=None if g is None else g.chosen)
    assert planned is not None  # grounded categories, or any entity
    step = planned.step
    if singular and b.size(step) > 1:
        n = b.size(step)
        if planned.anchor is not None:
            anchor = planned.anchor
            metric = planned.measure or b.distance_to(anchor)
            step = b.add(Op.ARGMIN, step, anchor, metric=metric)
            what = _CLOSEST_TO.get(metric, "both anchors")
            b.note(f"{n} candidates fit; took the one closest to {what}")
        else:
            closest = planner.closest_in_colour(step, target.attributes)
            if closest is not None:
                step = closest
                b.note(f"{n} candidates fit; took the one nearest in colour")
            else:
                step = b.add(Op.ARGMAX, step, metric=Metric.VOLUME)
                b.note(f"{n} candidates fit; took the largest")
    topological = bool(target.constraints) or ins.viewpoint is not None
    return _finish(b, ins, step), ("spatial" if topological else "intrinsic")


def _finish(b: ProgramBuilder, ins: Instruction, step: int) -> int:
    if ins.kind == "count":
        return b.add(Op.COUNT, step)
    if ins.kind == "exists":
        return b.add(Op.EXISTS, step)
    return step
