"""Stage 3 of the offline reasoner: planning and the decision (the program's steps).

Reads stage 2's :class:`~causalsplat.reason.ground.Grounded` instruction only.

* A referring expression names one entity: the grounded categories, narrowed by the
  target's relations (:class:`~causalsplat.reason.topology.Planner`); when several
  candidates are left (ranked whenever the program cannot tell that one is), the one
  closest to the anchor of the last relation is taken
  (horizontally for ``above`` and ``below``: the one most directly over or under it), or,
  with no anchor, the one nearest in colour to the phrase's colour word (by the stored
  colours, when it names one), else the largest; the explanation says so. A phrase with
  a colour word and relations is read three ways, the first that selects anything
  answering (:func:`_colour_or_relations`): colour and relations as said; relations as
  said, the nearest in colour of those that fit; the colour, its relations relaxed.
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

Nothing here runs the program: the alternatives are ``coalesce`` steps, and
:meth:`Decision.explain` keeps the notes that hold on the executed program.

The query type (stage 1's classification) follows from what the program does:
``counterfactual``; ``affordance`` (a need with a relation to an anchor);
``commonsense`` (a need alone); ``spatial`` (any relation or viewpoint); else
``intrinsic`` (categories, attributes and modifiers only: no topology).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, replace

from causalsplat.colors import colour_phrase
from causalsplat.reason._builder import SCENE, Because, Note, ProgramBuilder, ProgramTooLong
from causalsplat.reason.ground import Grounded, Grounding, is_named
from causalsplat.reason.parse import Instruction, NounPhrase
from causalsplat.reason.topology import COLOUR_CONTRADICTED, Planned, Planner
from queries import GraphQuery, Metric, Op, QueryResult


@dataclass(frozen=True, slots=True)
class Decision:
    """The program stages 1-3 chose and the notes explaining it."""

    program: GraphQuery
    notes: tuple[Note, ...]

    def explain(self, result: QueryResult) -> tuple[str, ...]:
        """The notes that hold on the executed program ``result``."""
        steps = result.steps
        lines = (n.render(steps) for n in self.notes if n.holds(steps, self.program))
        return tuple(dict.fromkeys(lines))


#: How the explanation names what a tie-break metric measures to (other: "both anchors").
_CLOSEST_TO = {
    Metric.DISTANCE: "the anchor",
    Metric.HORIZONTAL_DISTANCE: "the anchor, horizontally",
    Metric.BOX_DISTANCE: "the anchor's surface",
    Metric.END_DISTANCE: "an end of the anchor",
    Metric.CORNER_DISTANCE: "a corner of the anchor",
}


def decide(builder: ProgramBuilder, grounded: Grounded) -> Decision:
    """Plan and decide (module docstring); never raises on a grounded instruction. A
    description whose program would be longer than the language allows is planned again
    with less of it (its last relations, then its appearance words; the explanation says
    what was left out), and answered with nothing when even its bare kind is too much."""
    fresh = False
    for shorter, why in _shorter(grounded):
        # a referring expression first with every reading, then with the one it plans
        # first (the readings are its only alternatives)
        tries = (True, False) if shorter.instruction.kind == "refer" else (True,)
        for readings in tries:
            b = ProgramBuilder(builder.ctx) if fresh else builder
            fresh = True
            if why is not None:
                b.note(why)
            try:
                return _decide(b, shorter, readings=readings)
            except ProgramTooLong:
                continue
    b = ProgramBuilder(builder.ctx)
    b.note("the description is too long for one program: nothing was selected")
    return Decision(*b.program(_nothing(b), "intrinsic"))


def _shorter(grounded: Grounded) -> Iterator[tuple[Grounded, str | None]]:
    """``grounded`` as said, then with fewer of its target's relations, then without its
    target's appearance words, each with the note that says what was left out."""
    yield grounded, None
    ins, target = grounded.instruction, grounded.instruction.target
    if target is None:
        return
    relations = target.constraints
    for keep in range(len(relations) - 1, -1, -1):
        fewer = replace(ins, target=replace(target, constraints=relations[:keep]))
        yield (
            replace(grounded, instruction=fewer),
            (
                f"the last {len(relations) - keep} of its {len(relations)} relations were not"
                " used: the program would be too long"
            ),
        )
    words = target.attributes + target.not_attributes
    if words:
        bare = replace(target, constraints=(), attributes=(), not_attributes=())
        yield (
            replace(grounded, instruction=replace(ins, target=bare)),
            (
                f"its relations and the words {', '.join(words)} were not used: the program"
                " would be too long"
            ),
        )


def _decide(builder: ProgramBuilder, grounded: Grounded, *, readings: bool = True) -> Decision:
    ins = grounded.instruction
    planner = Planner(builder, ins, grounded.anchor_categories)
    if ins.kind == "counterfactual":
        answer, qtype = _counterfactual(builder, planner, grounded), "counterfactual"
    elif ins.kind == "action":
        answer, qtype = _need(builder, planner, grounded)
    else:
        answer, qtype = _referring(builder, planner, grounded, readings=readings)
    return Decision(*builder.program(answer, qtype))


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
    said = ", ".join(np.text for np in ins.removed)
    b.note(f"moved: {said}; what rests on it goes along" if ins.moved else f"removed: {said}")
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
    ins = grounded.instruction
    target = ins.target
    related = False
    if target is not None:
        wider = [c.category for c in g.candidates[:3] if c.score >= g.candidates[0].score * 0.5]
        for constraint in target.constraints:
            if not all(is_named(a) for a in constraint.anchors):
                b.note(f"relation {constraint.kind!r} not used: its anchor is not named")
                continue
            if g.chosen and set(g.chosen) <= {c for a in constraint.anchors for c in a.categories}:
                # "wash my hands at the sink": the sink, the place where it is done
                b.note(f"the need is met at {', '.join(g.chosen)} itself")
                continue
            out = planner.relation(step, constraint, singular=False, selectors=False)
            if out is None:
                continue
            alternatives: list[tuple[int, Because]] = [(_closest_if_singular(b, ins, out), None)]
            if not g.affordances and len(wider) > len(g.chosen):
                base = b.union([b.add(Op.FILTER_CATEGORY, SCENE, value=c) for c in wider])
                with b.capture() as notes:
                    retry = planner.relation(base, constraint, singular=False, selectors=False)
                    if retry is not None:
                        retried = _closest_if_singular(b, ins, retry)
                if retry is not None:
                    why = f"none of {', '.join(g.chosen)} fits the relation; tried the top 3"
                    alternatives.append((retried, [*notes, why]))
            if _definite(ins) and out.anchor not in (None, step):
                assert out.anchor is not None
                closest = b.add(Op.ARGMIN, step, out.anchor, metric=b.distance_to(out.anchor))
                why = f"nothing fits the relation {constraint.kind!r}; took the closest"
                alternatives.append((closest, why))
            else:
                alternatives.append(
                    (step, f"nothing fits the relation {constraint.kind!r}; it was not used")
                )
            step, related = b.coalesce(*alternatives), True
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
    if _definite(ins) and out.anchor is not None and not b.at_most_one(out.step):
        b.note("{n} fit; took the one closest to the anchor", more=out.step)
        return b.add(Op.ARGMIN, out.step, out.anchor, metric=b.distance_to(out.anchor))
    return out.step


def _referring(
    b: ProgramBuilder, planner: Planner, grounded: Grounded, *, readings: bool = True
) -> tuple[int, str]:
    ins = grounded.instruction
    target = ins.target
    assert target is not None
    singular = ins.kind == "refer"
    g: Grounding | None = grounded.target
    if g is not None and g.how != "named":
        b.note(g.describe())
    if g is not None and not g.fits:
        return _finish(b, ins, _nothing(b)), "intrinsic"
    categories = None if g is None else g.chosen
    topological = bool(target.constraints) or ins.viewpoint is not None
    qtype = "spatial" if topological else "intrinsic"
    if not singular:
        planned = planner.plan(target, singular=False, categories=categories)
        assert planned is not None  # grounded categories, or any entity
        return _finish(b, ins, planned.step), qtype
    contradicted = len(planner.contradicted)
    with b.capture() as said:
        planned = planner.plan(target, singular=True, categories=categories)
        assert planned is not None
        step = _one(b, planner, planned, target.attributes)
    read = None
    if (
        readings and target.constraints and len(planner.contradicted) == contradicted
        and planner.count == 1
    ):  # fmt: skip
        read = _colour_or_relations(b, planner, target, categories, planned, (step, said))
    if read is None:
        b.notes.extend(said)
    return _finish(b, ins, step if read is None else read), qtype


def _one(b: ProgramBuilder, planner: Planner, planned: Planned, words: tuple[str, ...]) -> int:
    """Of the candidates a singular phrase leaves, one: the one nearest the line between
    the two ends of a "between", else the closest to its last relation's anchor, else the
    one nearest in colour to its colour word, else the largest."""
    step = planned.step
    if b.at_most(step, planner.count):
        return step
    the = _the(planner.count)
    if planned.ends is not None:
        # "the trash can between the desk and the door": the one most squarely between
        b.note(f"{{n}} candidates fit; took {the} nearest the line between them", more=step)
        ends = b.add(Op.ARGMIN, step, *planned.ends, metric=Metric.SEGMENT_DISTANCE,
                     k=planner.k)  # fmt: skip
        return b.coalesce((ends, None), (step, None))
    if planned.anchor is not None:
        anchor = planned.anchor
        metric = planned.measure or b.distance_to(anchor)
        what = _CLOSEST_TO.get(metric, "both anchors")
        b.note(f"{{n}} candidates fit; took {the} closest to {what}", more=step)
        # none measured (the anchor is the candidate itself): it stays
        closest = b.add(Op.ARGMIN, step, anchor, metric=metric, k=planner.k)
        return b.coalesce((closest, None), (step, None))
    return _closest_in_colour_or_largest(b, planner, step, planned, words)


def _colour_or_relations(
    b: ProgramBuilder,
    planner: Planner,
    target: NounPhrase,
    categories: tuple[str, ...] | None,
    planned: Planned,
    as_planned: tuple[int, list[Note]],
) -> int | None:
    """A singular phrase with a colour word and relations ("the brown pillow on the
    sofa") read three ways, in this order: its colour and its relations as said; its
    relations as said, of those the one nearest in colour (the measured colours of a scan
    are dim and uneven: of the pillows on the sofa, the brownest, rather than the one
    brown pillow of the room, elsewhere); then ``as_planned`` (the colour, then the
    relations relaxed, with its notes). ``None`` (``as_planned`` alone) unless the colour
    word narrows the candidates and some that fit the relations may be called that (a
    colour the scene contradicts keeps its "none")."""
    soft = tuple(w for w in target.attributes if colour_phrase(w) is not None)
    if not soft or planned.base is None:
        return None
    rest = tuple(w for w in target.attributes if w not in soft)
    with b.capture() as uncoloured_notes:
        uncoloured = planner.plan(
            replace(target, attributes=rest), singular=True, categories=categories, strict=True
        )
    if uncoloured is None or uncoloured.base is None:
        return None
    if b.ids.get(uncoloured.base) == b.ids.get(planned.base):
        return None  # the colour word keeps every candidate: nothing to rank
    # only colours the word may name (what the scene would not contradict): "the red
    # pillow on the couch" is none of the couch's tan and white pillows
    tiers = planner.by_colour(uncoloured.step, uncoloured, soft, within=COLOUR_CONTRADICTED)
    if not tiers:
        return None
    with b.capture() as said_notes:
        said = planner.plan(target, singular=True, categories=categories, strict=True)
        assert said is not None
        exact = _one(b, planner, said, target.attributes)
    with b.capture() as ranked_notes:
        nearest = b.coalesce(*((t, None) for t in tiers))
        ranked = _one(b, planner, replace(uncoloured, step=nearest), soft)
    why = Note(f"no {' '.join(soft)} one fits its relations as said; of those that do,"
               " took the nearest in colour")  # fmt: skip
    return b.coalesce(
        (exact, said_notes),
        (ranked, [*uncoloured_notes, *ranked_notes, why]),
        as_planned,
    )


def _closest_in_colour_or_largest(
    b: ProgramBuilder, planner: Planner, step: int, planned: Planned, words: tuple[str, ...]
) -> int:
    """Of several candidates left for one, the one nearest in colour to the phrase's colour
    word (by the stored colours of the phrase's candidates, nearest first), else the
    largest."""
    by_colour = planner.by_colour(step, planned, words)
    n = planner.count
    largest = "{n} candidates fit; took the largest" + ("" if n == 1 else f" {n}")
    if not by_colour:
        b.note(largest, more=step)
        return b.add(Op.ARGMAX, step, metric=Metric.VOLUME, k=planner.k)
    nearest = Note(f"{{n}} candidates fit; took {_the(n)} nearest in colour", more=step)
    chosen = b.coalesce(*((s, nearest) for s in by_colour), (step, Note(largest, more=step)))
    return b.add(Op.ARGMAX, chosen, metric=Metric.VOLUME, k=planner.k)


def _the(n: int) -> str:
    """How an explanation says the ``n`` chosen: "the one", "the 2"."""
    return "the one" if n == 1 else f"the {n}"


def _finish(b: ProgramBuilder, ins: Instruction, step: int) -> int:
    if ins.kind == "count":
        return b.add(Op.COUNT, step)
    if ins.kind == "exists":
        return b.add(Op.EXISTS, step)
    return step
