"""Stage 2 of the offline reasoner: topological reasoning, as program steps.

:class:`Planner` turns the noun phrases of an :class:`~causalsplat.reason.parse.Instruction`
into steps of a :class:`~queries.GraphQuery`: candidates by category (and stored attribute),
then one step per relation to an anchor (anchors are planned the same way, recursively),
then modifiers (largest, tallest, leftmost, second from the right, the upper left: the
leftmost of the highest level...). Left and right rank
by ``rightward``, seen from the observer (the scene centre, the viewpoint, or the place the
observer stands at) looking at the candidates (the mean centroid of what the phrase can
select); "the middle one" is the language's ``middle``.

Nothing is run while planning: a choice that depends on what a step selects is written
into the program as a ``coalesce`` of the alternatives in order of preference (the
relation; its relaxations; the closest instead; the candidates, the relation unused), with
the note that explains each (:class:`~causalsplat.reason._builder.Note`). Which entities a
phrase's kinds and colour words select is read from the scene's entities
(:attr:`ProgramBuilder.ids <causalsplat.reason._builder.ProgramBuilder.ids>`).

A relation followed by another in the same phrase only selects ("the dresser under the bed,
farther from the desk": every dresser near the bed, if none is under it); the last one
chooses.

Relations, by kind (the singular case is a referring expression that must name one entity):

* stored relations (``supported_by``, ``supports``, ``above``, ``below``, ``inside``,
  ``contains``): ``relate``. When a singular phrase selects nothing, the relation is
  relaxed along :data:`RELAXATIONS` (``above`` -> ``supported_by`` -> ``near``) and finally
  to the candidate closest to the anchor, or, when the phrase has a selector of its own
  ("the highest picture on the wall"), to every candidate, for the selector to choose
  from; each relaxation is noted for the explanation.
* ``near`` / ``next to`` / ``beside``: for a singular phrase with no other selector,
  the candidate closest to the anchor (``argmin`` distance: Sr3D's reading of these
  words); otherwise the stored ``near`` relation.
* ``closest`` / ``farthest``: ``argmin`` / ``argmax`` of the distance to the anchor.
* ``between``: ``relate_between``; relaxed to "near both", then to the closest.
* ``left_of`` / ``right_of`` / ``in_front_of`` / ``behind``: ``relate`` with a viewpoint: the
  observer looks from the scene centre at the viewpoint entity ("facing the couch") or,
  without one, at the anchor (the language's default); standing *at* an entity, the
  observer looks from it towards the scene centre.
* ``with`` ("the desk with a monitor"): what ``supports`` the anchor, else what is near it.
* Negated relations ("not the one near the door") subtract the related set.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, replace

from causalsplat.colors import (
    BASIC,
    WORDS,
    colour_phrase,
    lightness,
    names_of,
    rgb_to_hex,
    word_distance,
    word_fits,
)
from causalsplat.reason._builder import SCENE, ProgramBuilder
from causalsplat.reason.parse import Constraint, Instruction, NounPhrase
from graph_store import Entity, RelationType
from queries import Metric, Op
from queries.model import MAX_K, MIN_VIEW_DISTANCE
from queries.semantics import PY, attribute_filter, metric_value, normalise_text

#: Candidates whose colour is within this (weighted Delta E) of the one nearest to a colour
#: word are kept with it: one measured colour never singles out an object on its own.
#: Measured on the ScanRefer and Nr3D *train* samples (1,000 descriptions each, colours of
#: the scans' object tables), for basic terms as for other colour words: a margin of 0
#: answers 60.5 / 67.2 % right, 10 62.9 / 67.4 % (7-13 within 0.4 points of it), 30
#: 62.5 / 66.7 %; keeping only the candidates whose colour is nearest to the word's basic
#: term (the rule before) 61.9 / 66.7 %: a lit or shaded colour is often nearer another.
COLOUR_MARGIN = 10.0
#: How far (CIELAB, :func:`causalsplat.colors.word_distance`) the nearest candidate may be
#: from a colour word before the scene contradicts the word. Measured on ScanRefer *train*
#: (first colour word of 599 descriptions, colours of the scans' object tables): 98 % of
#: targets are within 73 of the word they are called, 99 % within 77. On its 547
#: descriptions with the word replaced by an opposite no candidate is nearest to, 75 answers
#: 21.8 % of the variants rightly "none" and 1.1 % of the originals wrongly; the rule before
#: (65 beyond the distance to the candidate's own nearest colour name) 16.1 % and 1.3 %.
#: On the held-out ScanRefer val the gain was smaller: 14.2 -> 16.3 % rightly "none", and
#: 1.7 -> 2.1 % wrongly (docs/benchmarks.md, "None").
COLOUR_CONTRADICTED = 75.0
#: A scan's lighting makes its colours dimmer and greyer than the words people use, so a
#: candidate nearer to a word than COLOUR_CONTRADICTED may still not be that colour. The
#: rest of the scene shows what the word looks like under that lighting: when at least
#: COLOUR_SCENE_SHARE of the scene's other objects that store a colour are nearer to the
#: word than the nearest candidate, by COLOUR_SCENE_GAP or more, and that candidate is at
#: least COLOUR_SCENE_FLOOR from it, the scene contradicts the word too ("the black chair"
#: where the monitors and the bin measure black and the chairs brown). Measured on the
#: ScanRefer *train* sample (1,000 descriptions; 547 with a colour word replaced by an
#: opposite that no object of the target's label is nearest to): the distance alone answers
#: 20.7 % of the variants rightly "none" and 0.9 % of the originals wrongly, 666 of the
#: 1,000 right; with the scene's share 0.4, gap 10, floor 30: 32.7 %, 1.1 %, 664 right
#: (share 0.3: 38.0 %, 1.6 %, 662; gap 15: 30.3 %, 1.1 %, 665; gap 0: 51.0 %, 4.4 %, 644).
#: The Nr3D train sample answers the same 712 of 1,000 either way. On the held-out ScanRefer
#: val sample (535 variants) it generalised less well: 16.3 -> 28.0 % rightly "none",
#: 1.5 -> 3.0 % wrongly, 62.8 -> 62.3 % right (docs/benchmarks.md, "None").
COLOUR_SCENE_SHARE = 0.4
COLOUR_SCENE_GAP = 10.0
COLOUR_SCENE_FLOOR = 30.0
#: "the dark couch", "a light-coloured table": the candidates within this much lightness
#: (CIELAB L*) of the darkest or lightest are kept, as COLOUR_MARGIN keeps them by colour.
#: Shades and negated colours together: Nr3D / ScanRefer *train* samples 67.4 -> 67.6 % /
#: 63.0 -> 63.1 % (few descriptions use them; none answered worse on Nr3D, one on ScanRefer).
LIGHTNESS_MARGIN = 10.0
#: Kinds of request that ask about every candidate that fits, not one.
_EVERY = frozenset({"set", "count", "exists"})


def _is_colour(word: str) -> bool:
    """Whether an attribute word names a colour (not a shade alone)."""
    phrase = colour_phrase(word)
    return phrase is not None and phrase[0] is not None


#: How many colours, nearest first, :meth:`Planner.by_colour` tries before the largest
#: candidate is taken (one ``coalesce`` step).
COLOUR_TIERS = 7
STORED = ("supported_by", "supports", "above", "below", "inside", "contains")
VIEW = ("left_of", "right_of", "in_front_of", "behind")
#: How near a wall (horizontal gap between footprints, scene units) a candidate stands
#: "against the wall" when the phrase has more to choose with. Measured on the Nr3D /
#: ScanRefer train samples: 0.5 gives 760 / 690 right, 0.25 (the contact for a wall's
#: front) 760 / 689, without the rule 761 / 688.
AGAINST_WALL = 0.5
RELAXATIONS: dict[str, tuple[str, ...]] = {
    "above": ("supported_by", "near+z_max"),
    "below": ("supports", "near+z_min"),
    "supported_by": ("above", "near"),
    "supports": ("below", "near"),
    "inside": ("near",),
    "contains": ("near",),
    "left_of": (),
    "right_of": (),
    "in_front_of": (),
    "behind": (),
}
#: Relations between things stacked one over the other: of several candidates, the one
#: most directly over or under the anchor (horizontal distance) is meant. Measured on
#: 1,200 sampled Sr3D *train* vertical rows: above 91.0 % by 3D distance, 95.6 %
#: horizontally; below 91.0 % and 93.7 %.
VERTICAL = frozenset({"above", "below"})
#: "Across from X" looks from X into the room, unless X is this near the room's centre
#: (share of the horizontal half diagonal of all boxes), where it faces no way.
MIDDLE = 0.2

_WORDS = {
    "supported_by": "on", "supports": "supporting", "above": "above", "below": "below",
    "inside": "inside", "contains": "containing", "near": "near", "closest": "closest to",
    "opposite": "across from",
    "farthest": "farthest from", "between": "between", "left_of": "left of",
    "right_of": "right of", "in_front_of": "in front of", "behind": "behind",
    "with": "with", "end_of": "at the end of", "corner_of": "at the corner of",
    "side_with": "on the side with",
}  # fmt: skip
#: What a group's own extent counts at least, in scene units (metres), when the side of the
#: room it stands on is chosen by its gap to the others (:meth:`Planner._group_side`).
GROUP_EXTENT = 0.1
#: "At the end / corner of X": the candidate nearest an end (shorter edge) or a corner of
#: X's footprint, not its middle.
_FOOTPRINT = {"end_of": Metric.END_DISTANCE, "corner_of": Metric.CORNER_DISTANCE}


@dataclass(frozen=True, slots=True)
class Planned:
    """A planned noun phrase: its step, and the anchor step of its last relation (used to
    break ties: the candidate closest to it, by ``measure`` where the relation says how,
    else as :meth:`ProgramBuilder.distance_to` measures; of a "between", the candidate
    nearest the segments between its two ``ends``)."""

    step: int
    anchor: int | None = None
    ends: tuple[int, int] | None = None
    measure: Metric | None = None
    #: the phrase's candidates before relations (:meth:`Planner.candidates`)
    base: int | None = None


class Planner:
    """Plans noun phrases into steps of one :class:`ProgramBuilder`."""

    def __init__(
        self,
        builder: ProgramBuilder,
        instruction: Instruction,
        anchor_categories: (
            Callable[[NounPhrase], tuple[tuple[str, ...], str] | None] | None
        ) = None,
    ) -> None:
        self.b = builder
        self.ctx = builder.ctx
        self.instruction = instruction
        self._anchor_categories = anchor_categories
        # the viewpoint's own phrase is read from the default observer ("facing the room
        # with the sink to your right"): its sides must not refer back to the viewpoint
        self._placing_viewpoint = False
        #: colour words the scene contradicts (a description that fits nothing here)
        self.contradicted: list[str] = []
        #: the entities each candidates step selects (shared with the builder)
        self.ids = builder.ids
        #: anchor steps whose description the scene contradicts (they select nothing)
        self.contradicted_anchors: set[int] = set()
        #: plan the target's relations as said, with no relaxation or fallback (a reading
        #: that selects nothing when the scene does not fit it; see :meth:`plan`)
        self._strict = False
        #: how many each choosing step of the target keeps ("the two stools closest to the
        #: window"): the target phrase's count, 1 for anchors
        count = instruction.target.count if instruction.target is not None else None
        self.count = min(max(1, count or 1), MAX_K)
        #: a colour word keeps each candidate it may name (:func:`colours.word_fits`), not
        #: the nearest: the target of a question of every one, how many or whether any
        #: ("which stools are green?"), while its candidates are planned
        self._each_colour = False

    # -- candidates ----------------------------------------------------------------------

    def candidates(
        self, np: NounPhrase, *, role: str, categories: tuple[str, ...] | None = None
    ) -> int | None:
        """Step of the entities a phrase's words can name (before relations): the grounded
        ``categories`` when given, else those its words name; ``None`` when it names
        nothing the scene holds."""
        b = self.b
        if categories is None and not np.categories and role == "anchor":
            grounded = self._anchor_categories(np) if self._anchor_categories else None
            if grounded:
                categories, how = grounded
                b.note(f"anchor {np.text!r} read as {', '.join(categories)} (by {how})")
        categories = np.categories if categories is None else categories
        if np.is_any and not categories:
            # "on the side with two trash cans, the farthest one": one of them
            categories = next((c.anchors[0].categories for c in np.constraints
                               if c.kind == "side_with"), ())  # fmt: skip
        if np.is_any and not categories:
            step = self._non_structural()
        elif categories:
            step = b.union([b.add(Op.FILTER_CATEGORY, SCENE, value=c) for c in categories])
            wanted = {normalise_text(c) for c in categories}
            self.ids[step] = self._where(lambda e: normalise_text(e.category) in wanted)
        else:
            b.note(f"{role} {np.text!r}: the scene has nothing called that")
            return None
        for word in self._colours_to_use(step, np.attributes):
            step = self._attribute(step, word)
        for word in np.not_attributes:
            step = self._not_attribute(step, word)
        return step

    def _colours_to_use(self, step: int, words: tuple[str, ...]) -> tuple[str, ...]:
        """The attribute words to apply: of several colour words ("the green and blue
        chairs", "a blue-grey blanket"), one the scene contradicts is left out when another
        fits (the phrase names a mix, or colours of different members); when all are
        contradicted, all are kept (and nothing fits)."""
        colours = [w for w in words if _is_colour(w)]
        if len(colours) < 2:
            return words
        known = self._colours(self.ids[step])
        if len(known) < len(self.ids[step]) or not known:
            return words

        against = set()
        for word in colours:  # as :meth:`_colour` narrows, one word after the other
            name, shade = colour_phrase(word)  # type: ignore[misc]
            if self._contradiction(name, known, self.ids[step]) is not None:
                against.add(word)
            else:
                known = {i: known[i] for i in self._nearest(known, name, shade)}
        if not against or len(against) == len(colours):
            return words
        for word in sorted(against):
            self.b.note(f"nothing here is {word}; the word was not used (another colour fits)")
        return tuple(w for w in words if w not in against)

    def _where(
        self, keep: Callable[[Entity], bool], ids: tuple[int, ...] | None = None
    ) -> tuple[int, ...]:
        """Those of ``ids`` (default: every entity) for which ``keep`` holds, sorted."""
        by_id = self.ctx.by_id
        return tuple(i for i in (sorted(by_id) if ids is None else ids) if keep(by_id[i]))

    def _filter(self, step: int, key: str, value: str) -> int:
        """``filter_attribute`` of ``step``, with the entities it keeps (the language's rule:
        normalised key and value)."""
        text = f"{key}={value}"
        out = self.b.add(Op.FILTER_ATTRIBUTE, step, value=text)
        k, v = attribute_filter(Op.FILTER_ATTRIBUTE.value, text, self.ctx.config)
        self.ids[out] = self._where(
            lambda e: any(normalise_text(a.key) == k and normalise_text(a.value) == v
                          for a in e.attributes), self.ids[step])  # fmt: skip
        return out

    def _union(self, steps: list[int]) -> int:
        out = self.b.union(steps)
        self.ids[out] = tuple(sorted({i for st in steps for i in self.ids[st]}))
        return out

    def _none_of(self, step: int) -> int:
        """A step selecting nothing (the scene contradicts what was said of ``step``)."""
        out = self.b.add(Op.DIFFERENCE, step, step)
        self.ids[out] = ()
        return out

    def _non_structural(self) -> int:
        b = self.b
        structural = [c for c in self.ctx.categories if self.ctx.config.is_structural(c)]
        if not structural:
            return SCENE
        parts = [b.add(Op.FILTER_CATEGORY, SCENE, value=c) for c in structural]
        step = b.add(Op.DIFFERENCE, SCENE, b.union(parts))
        self.ids[step] = self._where(lambda e: not self.ctx.config.is_structural(e.category))
        return step

    def _attribute(self, step: int, word: str) -> int:
        b = self.b
        phrase = colour_phrase(word)
        if phrase is not None:
            name, shade = phrase
            if name is None:
                colour: int | None = self._lightness(step, word, shade)
            else:
                colour = self._colour(step, word, name, shade)
            if colour is not None:
                return colour
        filtered = self._stored(step, word)
        if filtered is None:
            return step
        if not self.ids[filtered]:
            b.note(f"nothing here is {word}; the word was not used")
            return step
        return filtered

    def _stored(self, step: int, word: str) -> int | None:
        """Those of ``step`` storing an attribute value spelt as ``word`` (``None`` when
        no entity of the scene stores one)."""
        wanted = normalise_text(word)
        pairs = [(k, v) for k, v in self.ctx.attribute_pairs() if normalise_text(v) == wanted]
        if not pairs:
            return None
        return self._union([self._filter(step, k, v) for k, v in pairs])

    def _not_attribute(self, step: int, word: str) -> int:
        """The candidates without an attribute ("not the white one"): the one a colour word
        fits best, or those a stored attribute value names, are dropped, unless that drops
        them all (the word then tells none apart)."""
        b = self.b
        phrase = colour_phrase(word)
        ids = self.ids[step]
        known = self._colours(ids)
        if phrase is not None and known:
            if len(known) < len(ids):
                return step
            name, shade = phrase
            if name is not None:
                keep = self._nearest(known, name, shade, margin=0.0)
            else:
                keep = self._darkest(known, shade, margin=0.0)
            with_it: int | None = self._keep_colours(step, [known[i] for i in keep])
        else:
            with_it = self._stored(step, word)
        if with_it is None or len(self.ids[with_it]) in (0, len(ids)):
            return step
        b.note(f"not {word}: {len(ids) - len(self.ids[with_it])} of {len(ids)} candidates")
        out = b.add(Op.DIFFERENCE, step, with_it)
        self.ids[out] = tuple(i for i in ids if i not in self.ids[with_it])
        return out

    def _nearest(
        self, known: dict[int, tuple[float, float, float]], name: str, shade: str | None,
        margin: float = COLOUR_MARGIN,
    ) -> list[int]:  # fmt: skip
        """Those of ``known`` within ``margin`` of the nearest to a colour word, shaded."""
        dist = {i: word_distance(name, rgb, shade) for i, rgb in known.items()}
        best = min(dist.values())
        return [i for i in known if dist[i] <= best + margin]

    def _darkest(
        self, known: dict[int, tuple[float, float, float]], shade: str | None,
        margin: float = LIGHTNESS_MARGIN,
    ) -> list[int]:  # fmt: skip
        """Those of ``known`` within ``margin`` (of L*) of the darkest, or for a light shade
        the lightest."""
        sign = 1.0 if shade == "dark" else -1.0
        level = {i: sign * lightness(rgb) for i, rgb in known.items()}
        best = min(level.values())
        return [i for i in known if level[i] <= best + margin]

    def _colour(self, step: int, word: str, name: str, shade: str | None) -> int | None:
        """A colour word, by perceptual distance to the candidates' stored colours
        (``rgb``; :mod:`causalsplat.colors`). When even the nearest candidate is farther
        than :data:`COLOUR_CONTRADICTED` from the word, the scene contradicts the word and
        nothing is kept; otherwise the candidates within
        :data:`COLOUR_MARGIN` of the nearest are, whatever basic term each one's colour
        is nearest to (a shaded grey chair whose measured colour is named black is "the
        gray chair" when no chair is nearer to gray). A shade ("dark brown") ranks the
        candidates by the shaded word; the scene contradicts the word alone. When some
        candidates store a colour name but no ``rgb``, a basic term selects those it names.
        ``None`` (match stored names as written) when no candidate stores a colour."""
        b = self.b
        term = names_of(WORDS[name])[0]
        ids = self.ids[step]
        known = self._colours(ids)
        if not known:
            return self._colour_names(step, word, term, ids)
        if name in BASIC and len(known) < len(ids):
            # some candidates store a colour name only: names are what all can be held to
            if any(term in self._names(i) for i in ids):
                return self._filter(step, "color", term)
            return step
        dist = {i: word_distance(name, rgb) for i, rgb in known.items()}
        why = self._contradiction(name, known, ids)
        if why is not None:
            closest = sorted(known, key=lambda i: dist[i])[:3]
            self.contradicted.append(word)
            closest_text = ", ".join(f"#{i} {rgb_to_hex(known[i])}" for i in closest)
            b.note(f"the scene contradicts {word!r}: nothing here is {word} (closest: "
                   f"{closest_text}){why}")  # fmt: skip
            return self._none_of(step)
        if self._each_colour:
            keep = [i for i in known if word_fits(name, known[i], shade)]
            if not keep:
                b.note(f"{word}: none of the {len(ids)} candidates is {word}")
                return self._none_of(step)
        else:
            keep = self._nearest(known, name, shade)
        if len(keep) == len(ids):
            return step
        b.note(f"{word}: {len(keep)} of {len(ids)} candidates by colour")
        return self._keep_colours(step, [known[i] for i in keep])

    def _contradiction(
        self, name: str, known: dict[int, tuple[float, float, float]], ids: tuple[int, ...]
    ) -> str | None:
        """Whether the scene contradicts the colour word ``name`` for the candidates ``ids``
        (``known``: the stored colours of those that have one, narrowed by any colour word
        before): ``None`` when it does not, else the note's tail (empty
        when the nearest candidate is farther than :data:`COLOUR_CONTRADICTED` from the
        word; the count of nearer objects when the rest of the scene decides, see
        :data:`COLOUR_SCENE_SHARE`)."""
        best = min(word_distance(name, rgb) for rgb in known.values())
        if best > COLOUR_CONTRADICTED:
            return ""
        if best <= COLOUR_SCENE_FLOOR:
            return None
        others = [d for i, d in self._scene_distances(name).items() if i not in ids]
        nearer = sum(d < best - COLOUR_SCENE_GAP for d in others)
        if not others or nearer < COLOUR_SCENE_SHARE * len(others):
            return None
        return f"; {nearer} of {len(others)} other objects are nearer to {name}"

    def _scene_distances(self, name: str) -> dict[int, float]:
        """Each entity's distance (of those that store a colour) to the colour word
        ``name``, computed once per scene and word."""
        key = f"colour-distances:{name}"
        if key not in self.ctx.cache:
            self.ctx.cache[key] = {
                e.id: word_distance(name, rgb)
                for e in self.ctx.graph.entities
                if (rgb := self.ctx.colour(e.id)) is not None
            }
        return self.ctx.cache[key]  # type: ignore[no-any-return]

    def _lightness(self, step: int, word: str, shade: str | None) -> int:
        """A shade said alone ("the dark couch", "the lighter-coloured table"): the
        candidates within :data:`LIGHTNESS_MARGIN` of the darkest or lightest stored
        colour; compared ("the darker one", "the lightest stool"), the darkest or lightest
        alone. Unchanged unless every candidate stores a colour and they differ."""
        b = self.b
        ids = self.ids[step]
        known = self._colours(ids)
        if len(known) < 2 or len(known) < len(ids):
            return step
        compared = word.split()[0].endswith(("er", "est"))
        keep = self._darkest(known, shade, margin=0.0 if compared else LIGHTNESS_MARGIN)
        if len(keep) == len(ids):
            return step
        b.note(f"{word}: {len(keep)} of {len(ids)} candidates by lightness")
        return self._keep_colours(step, [known[i] for i in keep])

    def _names_nothing(self, np: NounPhrase) -> bool:
        """Whether ``np`` names nothing the scene holds, even grounded by meaning."""
        if np.is_any or np.categories:
            return False
        return self._anchor_categories is None or not self._anchor_categories(np)

    def _part_colours(self, step: int, part: NounPhrase) -> int:
        """The colour of a part the scene does not hold as an object ("the monitor with a
        pink screen", "it has a tan background") is some of the target's own: of ``step``,
        those within :data:`COLOUR_MARGIN` of the nearest to each colour word. A part is a
        share of its object's mean colour, so the word only ranks: it never contradicts."""
        for word in part.attributes:
            phrase = colour_phrase(word)
            ids = self.ids[step]
            if phrase is None or phrase[0] is None or len(ids) < 2:
                continue
            known = self._colours(ids)
            if len(known) < len(ids):
                continue
            keep = self._nearest(known, phrase[0], phrase[1])
            if len(keep) == len(ids):
                continue
            self.b.note(f"{part.text!r} is part of it: {word}, {len(keep)} of {len(ids)}"
                        " candidates by colour")  # fmt: skip
            step = self._keep_colours(step, [known[i] for i in keep])
        return step

    def _keep_colours(self, step: int, colours: list[tuple[float, float, float]]) -> int:
        """Those of ``step`` of the stored ``colours``: one filter per colour kept, or, when
        every candidate stores one and fewer are dropped, the candidates less one filter per
        colour dropped (18 of 28 chairs are 10 steps, not 18)."""
        values = sorted({rgb_to_hex(c) for c in colours})
        ids = self.ids[step]
        known = self._colours(ids)
        others = sorted({rgb_to_hex(rgb) for rgb in known.values()} - set(values))
        if len(known) == len(ids) and 0 < len(others) < len(values):
            dropped = self._union([self._filter(step, "rgb", v) for v in others])
            out = self.b.add(Op.DIFFERENCE, step, dropped)
            self.ids[out] = tuple(i for i in ids if i not in self.ids[dropped])
            return out
        return self._union([self._filter(step, "rgb", v) for v in values])

    def by_colour(
        self, step: int, planned: Planned, words: tuple[str, ...], *, within: float | None = None
    ) -> list[int]:
        """Those of ``step`` of each colour the phrase's candidates have, nearest to the
        phrase's colour word first (the nearest :data:`COLOUR_TIERS`; equally near colours
        together), for a choice among several left for one; ``within``: only colours this
        near the word. ``[]`` without a colour word, or with fewer than two candidates
        storing a colour."""
        colour = next((p for w in words if (p := colour_phrase(w)) and p[0] is not None), None)
        if colour is None or planned.base is None:
            return []
        known = self._colours(self.ids[planned.base])
        if len(known) < 2:
            return []
        name, shade = colour
        assert name is not None
        tiers: dict[float, set[str]] = {}
        for rgb in known.values():
            distance = word_distance(name, rgb, shade)
            if within is None or distance <= within:
                tiers.setdefault(distance, set()).add(rgb_to_hex(rgb))
        b = self.b
        return [
            b.union([b.add(Op.FILTER_ATTRIBUTE, step, value=f"rgb={h}") for h in sorted(hexes)])
            for _, hexes in sorted(tiers.items())[:COLOUR_TIERS]
        ]

    def _colours(self, ids: tuple[int, ...]) -> dict[int, tuple[float, float, float]]:
        """The stored colours of those of ``ids`` that have one."""
        out = {}
        for i in ids:
            rgb = self.ctx.colour(i)
            if rgb is not None:
                out[i] = rgb
        return out

    def _names(self, entity_id: int) -> tuple[str, ...]:
        """The entity's stored colour names."""
        return self.ctx.by_id[entity_id].attribute_values("color")

    def _colour_names(self, step: int, word: str, term: str, ids: tuple[int, ...]) -> int | None:
        """Candidates that store colour names only (an objects file's ``color``): when
        every one has a name and none is the word or its basic term, the scene contradicts
        the word; otherwise ``None`` (the stored names are matched as written)."""
        names = [self._names(i) for i in ids]
        if not ids or not all(names):
            return None
        wanted = {normalise_text(word), term}
        if any(wanted & {normalise_text(v) for v in n} for n in names):
            return None
        self.contradicted.append(word)
        seen = sorted({v for n in names for v in n})
        self.b.note(f"the scene contradicts {word!r}: the candidates are {', '.join(seen)}")
        return self._none_of(step)

    # -- noun phrases --------------------------------------------------------------------

    def plan(
        self,
        np: NounPhrase,
        *,
        singular: bool,
        role: str = "target",
        categories: tuple[str, ...] | None = None,
        strict: bool = False,
    ) -> Planned | None:
        """Candidates (``categories`` when grounded), then relations, then modifiers;
        ``strict``: the phrase's own relations exactly as said, none relaxed and no
        fallback when one selects nothing (its anchors are planned as usual)."""
        with self._as_said(strict or self._strict):
            return self._plan(np, singular=singular, role=role, categories=categories)

    @contextmanager
    def _as_said(self, strict: bool) -> Iterator[None]:
        """Relations planned strictly (or not) inside the block, as before after it."""
        before, self._strict = self._strict, strict
        try:
            yield
        finally:
            self._strict = before

    def _plan(
        self,
        np: NounPhrase,
        *,
        singular: bool,
        role: str,
        categories: tuple[str, ...] | None,
    ) -> Planned | None:
        every = role == "target" and not singular and self.instruction.kind in _EVERY
        self._each_colour = every and sum(_is_colour(w) for w in np.attributes) == 1
        try:
            step = self.candidates(np, role=role, categories=categories)
        finally:
            self._each_colour = False
        if step is None:
            return None
        for c in np.constraints:
            if c.kind == "with" and not c.negated and self._names_nothing(c.anchors[0]):
                step = self._part_colours(step, c.anchors[0])
        for metric, direction in np.not_extremes:
            if not self.b.at_most_one(step):
                # "the stool that is not the tallest": every one but the tallest of its
                # kind, before relations choose among them
                there = self._extreme(step, metric, direction)
                if there != step:
                    step = self.b.add(Op.DIFFERENCE, step, there)
        last = Planned(step)
        base = step
        selectors = bool(np.extremes or np.not_extremes or np.side or np.ordinal or np.place)
        final = len(np.constraints) - 1
        # "the second closest to the window": the ordinal ranks the last closest/farthest
        extremal = [
            k for k, c in enumerate(np.constraints)
            if c.kind in ("closest", "farthest") and not c.negated
        ]  # fmt: skip
        ranked = extremal[-1] if extremal else -1
        if (
            ranked >= 0 and np.side in ("left", "right") and not np.side_negated
            and not np.ordinal and not np.extremes and not self.b.at_most_one(step)
        ):  # fmt: skip
            # "the closest chair on the left", "the lamp on the left that is closest to the
            # windows": of those on that side, the closest (before, the closest alone,
            # the side left out once one was chosen)
            step = self._side_half(step, np.side)
        for k, constraint in enumerate(np.constraints):
            # a relation with more to come leaves the choosing to what comes ("the dresser
            # under the bed, farther from the desk"): it selects, never picks one
            nth = np.ordinal if k == ranked and not np.side and (np.ordinal or 0) > 1 else 1
            if (
                k == ranked
                and not np.side
                and (np.ordinal or 0) < -1
                and constraint.kind == "farthest"
            ):
                nth = -(np.ordinal or 0)  # "the next to last from the window": 2nd farthest
            out = self.relation(step, constraint, singular=singular,
                                selectors=selectors or k < final, nth=nth,
                                after=last.anchor)  # fmt: skip
            if out is not None:
                step, last = out.step, out
        step = self.place(step, np, base)
        step = self.modifiers(step, np, base)
        return Planned(step, last.anchor, last.ends, last.measure, base)

    @property
    def k(self) -> int | None:
        """The ``k`` of a choosing step: ``None`` (one) unless the target asks for more."""
        return self.count if self.count > 1 else None

    @contextmanager
    def _one_each(self) -> Iterator[None]:
        """Choosing steps keep one inside the block (an anchor's: "the two stools closest
        to the largest table" keeps one table)."""
        before, self.count = self.count, 1
        try:
            yield
        finally:
            self.count = before

    def anchor(self, np: NounPhrase) -> int | None:
        contradicted = len(self.contradicted)
        with self._as_said(False), self._one_each():
            planned = self.plan(np, singular=False, role="anchor")
        if planned is None:
            return None
        assert planned.base is not None
        if not self.ids[planned.base]:
            self.b.note(f"anchor {np.text!r}: nothing fits")
            # the scene holds the anchor's kind but contradicts its description ("the bed
            # next to the blue nightstand" where the nightstand is brown): nothing is
            # related to it, rather than dropping what was said
            if len(self.contradicted) == contradicted:
                return None
            self.contradicted_anchors.add(planned.step)
            return planned.step
        if not np.constraints:
            return planned.step
        # "the end of the desk with a chair in front of it": where the anchor's own
        # relation fits none of its kind, the anchor is every one of that kind
        with self.b.capture() as notes:
            bare = self.plan(replace(np, constraints=()), singular=False, role="anchor")
        if bare is None:
            return planned.step
        alone = f"anchor {np.text!r}: none fits its own relation; took it alone"
        return self.b.coalesce((planned.step, None), (bare.step, [*notes, alone]))

    # -- relations -----------------------------------------------------------------------

    def relation(
        self, step: int, c: Constraint, *, singular: bool, selectors: bool, nth: int = 1,
        after: int | None = None,
    ) -> Planned | None:  # fmt: skip
        """Apply one relation to the candidates at ``step`` (module docstring); ``nth``:
        of ``closest`` / ``farthest``, the nth closest / farthest; ``after``: the anchor
        of the relation before it, if any."""
        anchors = [self.anchor(a) for a in c.anchors]
        if any(a is None for a in anchors):
            self.b.note(f"relation {_WORDS.get(c.kind, c.kind)!r} dropped: its anchor is unknown")
            return None
        a = [x for x in anchors if x is not None]
        if c.kind == "side_with":
            there = self._side_with(step, a[0], c.anchors[0])
            if there is not None and c.negated:
                there = self.b.add(Op.DIFFERENCE, step, there)  # "not on the side with two"
            return None if there is None else Planned(there, None)
        if not c.negated and self.contradicted_anchors.intersection(a):
            # nothing is related to what is not here: no relaxation, no closest instead
            return Planned(self._none_of(step), None)
        if c.kind == "near" and not c.negated and a == [after]:
            # "at the end of the table and close to the counter", the counter read as the
            # table: near what it was just related to says nothing more
            self.b.note(f"'near' {c.anchors[0].text!r}: the anchor before it again; not used")
            return None
        related = self._related(step, c.kind, a, singular=singular and not c.negated,
                                selectors=selectors, nth=nth)  # fmt: skip
        if c.negated:
            out = self.b.add(Op.DIFFERENCE, step, related)
            if singular and not self._strict:
                # "the chair that is not at a desk" when every chair is near one: the one
                # farthest from them
                anchor = a[0] if len(a) == 1 else self.b.union(a)
                farthest = self.b.add(Op.ARGMAX, step, anchor, metric=self.b.distance_to(anchor))
                if c.kind in ("near", "closest") and not selectors:
                    # "the trash can not near the kitchen" when none is near it by the
                    # stored relation: of the rest, the one farthest from it (what comes
                    # after it, a side or another relation, chooses otherwise)
                    out = self.b.add(Op.ARGMAX, out, anchor, metric=self.b.distance_to(anchor))
                out = self.b.coalesce((out, None), (farthest, f"every candidate is"
                    f" {_WORDS.get(c.kind, c.kind)} it; took the farthest instead"))  # fmt: skip
            return Planned(out, None)
        anchor = a[0] if len(a) == 1 else self.b.union(a)
        if singular and anchor == step and not self._strict:
            # "the trash can next to another trash can" when the words leave one trash can
            # (see _fallback)
            related = self.b.coalesce((related, None), (step, f"{_WORDS.get(c.kind, c.kind)!r}:"
                " its anchor is the candidates themselves; the relation was not used"))  # fmt: skip
        measure = Metric.HORIZONTAL_DISTANCE if c.kind in VERTICAL else _FOOTPRINT.get(c.kind)
        if (
            singular and not selectors and c.kind in ("left_of", "right_of")
            and (c.far or self._same_kind(step, anchor)) and not self.b.at_most_one(related)
        ):  # fmt: skip
            # "to the far right of the table", "to the right of another chair": of those
            # right of it (of the others of their kind), the rightmost
            where = self._mean_centroid(self.b.within(anchor))
            eye = self._observer() or list(self.ctx.centre)
            view = self._viewpoint(c.kind) or {"eye": eye, "target": where}
            op = Op.ARGMAX if c.kind == "right_of" else Op.ARGMIN
            if where is not None and math.dist(eye[:2], where[:2]) >= MIN_VIEW_DISTANCE:
                said = f"far {_WORDS[c.kind]} it" if c.far else f"{_WORDS[c.kind]} another"
                self.b.note(f"{said}: the {c.kind[:-3]}most of them")
                related = self.b.add(op, related, metric=Metric.RIGHTWARD, viewpoint=view)
        ends = (a[0], a[-1]) if c.kind == "between" else None
        return Planned(related, anchor, ends=ends, measure=measure)

    def _same_kind(self, step: int, anchor: int) -> bool:
        """Whether every category the anchor can hold is one of the candidates'."""
        mine, theirs = self.b.categories(step), self.b.categories(anchor)
        return bool(mine) and bool(theirs) and set(theirs) <= set(mine)

    def _related(
        self, step: int, kind: str, a: list[int], *, singular: bool, selectors: bool, nth: int = 1
    ) -> int:
        b = self.b
        if kind in ("closest", "farthest"):
            op, metric = Op.ARGMIN if kind == "closest" else Op.ARGMAX, b.distance_to(a[0])
            if kind == "closest" and metric is Metric.DISTANCE:
                # "the chair closest to the bookshelf": the one against it, however deep
                # the shelf; of those inside its box, the one nearer its centroid
                metric = Metric.BOX_CENTROID_DISTANCE
            first = b.add(op, step, a[0], metric=metric, k=self.k)
            if nth <= 1:
                return first
            upto = b.add(op, step, a[0], metric=metric, k=nth)
            before = b.add(op, step, a[0], metric=metric, k=nth - 1)
            # fewer than nth to rank: the closest (farthest)
            return b.coalesce((b.add(Op.DIFFERENCE, upto, before), None), (first, None))
        if kind == "opposite":
            return self._opposite(step, a[0], singular=singular, selectors=selectors)
        if kind in _FOOTPRINT:
            if singular and not selectors:
                return b.add(Op.ARGMIN, step, a[0], metric=_FOOTPRINT[kind], k=self.k)
            kind = "near"
        if kind == "near" and singular and not selectors:
            return b.add(Op.ARGMIN, step, a[0], metric=b.distance_to(a[0]), k=self.k)
        if kind == "between":
            # "between the two chairs": one anchor set whose members are both ends (an
            # entity is never between an anchor and itself, so A x A pairs distinct ends).
            return self._between(step, a[0], a[1] if len(a) > 1 else a[0], singular=singular)
        if kind == "with":
            out = b.coalesce(
                (b.add(Op.RELATE, step, a[0], relation=RelationType.SUPPORTS), None),
                (b.add(Op.RELATE, step, a[0], relation=RelationType.NEAR), None),
            )
            if not singular or self._strict:
                return out
            return b.coalesce((out, None), *self._fallback(step, a[0], "with", selectors))
        relation = "near" if kind == "near" else kind
        view = self._viewpoint(kind) or self._facing(kind, a[0])
        out = b.add(Op.RELATE, step, a[0], relation=RelationType(relation), viewpoint=view)
        if not singular or self._strict:
            return out
        alternatives: list[tuple[int, str | None]] = [(out, None)]
        for alt in RELAXATIONS.get(kind, ()):
            relation, _, extreme = alt.partition("+")
            relaxed = b.add(Op.RELATE, step, a[0], relation=RelationType(relation))
            if extreme and not selectors:
                op = Op.ARGMAX if extreme == "z_max" else Op.ARGMIN
                relaxed = b.add(op, relaxed, metric=Metric.Z)
                which = "highest" if op is Op.ARGMAX else "lowest"
                why = f"nothing is {_WORDS[kind]} it; took the {which} of what is near it"
            else:
                why = f"nothing is {_WORDS[kind]} it; read as {_WORDS[relation]!r} instead"
            alternatives.append((relaxed, why))
        if kind == "supported_by" and not selectors and not self._structural(a[0]):
            # "the plant on top of the counter", nothing on, above or near the counter:
            # what stands on furniture is raised off the floor, wherever it is
            highest = b.add(Op.ARGMAX, step, metric=Metric.Z)
            alternatives.append((highest, "nothing is on it or near it; took the highest"))
        return b.coalesce(*alternatives, *self._fallback(step, a[0], kind, selectors))

    def _structural(self, anchor: int) -> bool:
        """Whether the anchor is (or may be) a wall, a floor or a ceiling: unknown members
        count as structural."""
        ids = self.b.within(anchor)
        return ids is None or any(self.ctx.is_structural(self.ctx.by_id[i]) for i in ids)

    def _fallback(
        self, step: int, anchor: int, kind: str, selectors: bool
    ) -> list[tuple[int, str | None]]:
        """What a singular phrase keeps when its relation selects nothing (alternatives for
        :meth:`ProgramBuilder.coalesce`): with a selector of its own ("the top picture on
        the wall"), every candidate, for the selector to choose from (those other than the
        anchor first, when the anchor is one of them: "a large shelf next to the tall
        one"); else the candidate closest to the anchor; when every anchor is a candidate
        itself ("the trash can left of another trash can" when the words leave one trash
        can: nothing is related to itself, and the one left is meant), every candidate."""
        b, word = self.b, _WORDS.get(kind, kind)
        alone = (step, f"nothing is {word} it; the relation was not used")
        if selectors:
            mine = self.ids.get(step)  # the phrase's candidates, when no relation came before
            theirs = b.within(anchor) if mine else None
            if (
                mine and theirs and set(theirs) & set(mine)
                and (set(mine) - set(theirs) or (b.at_most_one(anchor) and len(mine) > 1))
            ):  # fmt: skip
                # "a large shelf next to the tall one": whatever else, not the tall one
                others = b.add(Op.DIFFERENCE, step, anchor)
                return [(others, f"nothing is {word} it; took the others of its kind"), alone]
            against = self._against(step, anchor, kind)
            return [against, alone] if against is not None else [alone]
        closest = b.add(Op.ARGMIN, step, anchor, metric=b.distance_to(anchor))
        return [(closest, f"nothing is {word} it; took the closest instead"), alone]

    def _against(self, step: int, anchor: int, kind: str) -> tuple[int, str] | None:
        """ "Against the wall", "on the far wall" (a chair, a shelf), with more to choose
        from: the candidates standing within :data:`AGAINST_WALL` of the walls the anchor
        holds, read off the entities while planning and written as
        the ``k`` nearest them (stored relations never relate an entity to a wall). ``None``
        when the anchor holds anything but walls, a relation came before (the candidates
        are not known without reading the program), or none or every one stands against
        them."""
        if kind not in ("near", "supported_by"):
            return None
        walls = self.b.within(anchor)
        if not walls or not set(walls) <= {w.id for w in self.ctx.walls()}:
            return None
        ids = self.ids.get(step)  # the phrase's candidates, when no relation came before
        if not ids:
            return None
        close = [i for i in ids if min(self.ctx.wall_gap(i, w) for w in walls) <= AGAINST_WALL]
        if not close or len(close) == len(ids):
            return None
        out = self.b.add(Op.ARGMIN, step, anchor, metric=Metric.BOX_DISTANCE, k=len(close))
        return out, f"nothing is {_WORDS.get(kind, kind)} it; took the {len(close)} against it"

    def _opposite(self, step: int, anchor: int, *, singular: bool, selectors: bool) -> int:
        """ "Across from X", "opposite X": seen from X looking the way its front faces
        (one X whose ``facing`` is stored: "the door across from the foot of the bed"), or
        else into the room (towards the scene centre), the candidate farthest ahead
        (``argmax`` of ``forward``); with more to choose, those ahead of X (``behind`` it,
        seen from it: the quarter of the room it faces). X without a front in the middle of
        the room (within :data:`MIDDLE` of the half diagonal from its centre) faces no way:
        the closest to it. Nr3D train sample (1,000): the front 714 -> 717 right; of the
        candidates ahead, the one in the middle of the view or the closest to X instead of
        the farthest: 715 (ScanRefer train 665 -> 663)."""
        b = self.b
        ids = b.within(anchor)
        where = self._mean_centroid(ids)
        centre = list(self.ctx.centre)
        near_middle = max(MIN_VIEW_DISTANCE, MIDDLE * self.ctx.half_diagonal)
        front = self._front_view(ids)
        if front is not None:  # at X, looking the way the observer in front of it looks back
            view = {"eye": front["target"], "target": front["eye"]}
        elif where is None or math.dist(where[:2], centre[:2]) < near_middle:
            return self._related(step, "closest", [anchor], singular=singular, selectors=selectors)
        else:
            view = {"eye": where, "target": centre}
        # the words may leave the anchor itself ("the chair opposite the chair")
        others = b.coalesce((b.add(Op.DIFFERENCE, step, anchor), None), (step, None))
        if singular and not selectors:
            return b.add(Op.ARGMAX, others, metric=Metric.FORWARD, viewpoint=view)
        ahead = b.add(Op.RELATE, others, anchor, relation=RelationType.BEHIND, viewpoint=view)
        return b.coalesce((ahead, None), (others, None)) if singular else ahead

    def _between(self, step: int, a1: int, a2: int, *, singular: bool) -> int:
        b = self.b
        out = b.add(Op.RELATE_BETWEEN, step, a1, a2)
        if not singular or self._strict:
            return out
        near = b.add(
            Op.INTERSECT,
            b.add(Op.RELATE, step, a1, relation=RelationType.NEAR),
            b.add(Op.RELATE, step, a2, relation=RelationType.NEAR),
        )
        either = b.union([a1, a2])
        closest = b.add(Op.ARGMIN, step, either, metric=b.distance_to(either))
        return b.coalesce(
            (out, None),
            (near, "nothing lies strictly between them; took what is near both"),
            (closest, "nothing lies between them; took the closest to either"),
        )

    # -- viewpoints and modifiers ------------------------------------------------------

    def _viewpoint(self, kind: str) -> dict[str, list[float]] | None:
        """An explicit viewpoint for view-dependent relations, or ``None`` (the default:
        from the scene centre towards the anchor)."""
        ins = self.instruction
        if kind not in VIEW or ins.viewpoint is None:
            return None
        ids = self._viewpoint_ids(ins.viewpoint)
        where = self._mean_centroid(ids)
        if where is None:
            return None
        observer = self._observer()
        if observer is None and not ins.standing_at:
            # "looking at the front of the toilet": where the toilet's front is known, the
            # observer stands in front of it
            front = self._front_view(ids)
            if front is not None:
                return front
        centre = observer or list(self.ctx.centre)
        if math.hypot(where[0] - centre[0], where[1] - centre[1]) < MIN_VIEW_DISTANCE:
            return None  # no direction to look in: the default viewpoint
        if ins.standing_at:
            return {"eye": where, "target": centre}
        return {"eye": centre, "target": where}

    def _facing(self, kind: str, anchor: int) -> dict[str, list[float]] | None:
        """For a view-dependent relation to one anchor whose front is known (``facing``),
        the observer in front of it looking at it: "the table in front of the cabinet" is
        in front of the cabinet's doors, wherever the middle of the room is."""
        if kind not in VIEW:
            return None
        return self._front_view(self.b.within(anchor), walls=True)

    def _front_view(
        self, ids: tuple[int, ...] | None, *, walls: bool = False
    ) -> dict[str, list[float]] | None:
        """The observer a metre in front of the one entity ``ids``, looking at it, when its
        front is known (with ``walls``, also when it is against a wall); else ``None``."""
        if not ids or len(ids) != 1:
            return None
        facing, how = self.ctx.facing(ids[0]), "the front of"
        if facing is None and walls:
            facing, how = self.ctx.wall_facing(ids[0]), "the room, facing"
        if facing is None:
            return None
        c = self.ctx.by_id[ids[0]].centroid
        self.b.note(f"seen from {how} {self.ctx.by_id[ids[0]].category!r}")
        return {"eye": [c[0] + facing[0], c[1] + facing[1], c[2]], "target": list(c)}

    def _observer(self) -> list[float] | None:
        """Where the observer stands when the instruction says it ("standing at the door
        looking at the windows"), else ``None`` (the scene centre)."""
        at = self.instruction.observer_at
        return None if at is None else self._centroid_of(at)

    def _centroid_of(self, np: NounPhrase) -> list[float] | None:
        return self._mean_centroid(self._viewpoint_ids(np))

    def _viewpoint_ids(self, np: NounPhrase) -> tuple[int, ...] | None:
        if self._placing_viewpoint:
            return None
        self._placing_viewpoint = True
        try:
            planned = self.plan(np, singular=False, role="viewpoint")
        finally:
            self._placing_viewpoint = False
        if planned is None:
            return None
        ids = self.b.within(planned.step)
        if np is self.instruction.viewpoint and not self.instruction.standing_at:
            ids = self._faced(ids)
        return ids

    def _faced(self, ids: tuple[int, ...] | None) -> tuple[int, ...] | None:
        """Of several entities a viewpoint faces ("facing the windows", "facing the wall
        with bags on it"), the one nearest the target's candidates: the observer faces the
        window the monitors stand by, not the middle of windows on opposite walls. A group
        the target is one of is faced as a whole ("facing the three chairs, the right
        one")."""
        target = self.instruction.target
        if not ids or len(ids) == 1 or target is None or not target.categories:
            return ids
        wanted = set(target.categories)
        cands = tuple(e.id for e in self.ctx.by_id.values() if e.category in wanted)
        middle = self._mean_centroid(cands)
        if middle is None or set(cands) & set(ids):
            return ids

        def away(i: int) -> tuple[float, int]:
            c = self.ctx.by_id[i].centroid
            return math.dist(c[:2], middle[:2]), i

        return (min(ids, key=away),)

    def _mean_centroid(self, ids: tuple[int, ...] | None) -> list[float] | None:
        """The mean centroid of the entities ``ids`` (``None`` for none, or unknown)."""
        if not ids:
            return None
        pts = [self.ctx.by_id[i].centroid for i in ids]
        return [math.fsum(p[k] for p in pts) / len(pts) for k in range(3)]

    def place(self, step: int, np: NounPhrase, base: int) -> int:
        """Where in the room the phrase's entity stands, among ``step``: in the corner
        (farthest from the scene centre, horizontally), in the middle of the room
        (closest to the centre) or by itself (farthest from the nearest other entity of
        ``base``, the phrase's candidates before relations); negated, every other one."""
        b = self.b
        if np.place is None or np.side or (np.ordinal or 1) != 1:
            # "the third one in the corner" counts along a row; "the first one, in the
            # corner" says only where it is
            return step
        if np.place == "corner":
            there = b.add(Op.ARGMAX, step, metric=Metric.HORIZONTAL_DISTANCE)
        elif np.place == "centre":
            there = b.add(Op.ARGMIN, step, metric=Metric.HORIZONTAL_DISTANCE)
        else:
            there = b.add(Op.ARGMAX, step, base, metric=Metric.DISTANCE)
        if np.place_negated:
            there = b.add(Op.DIFFERENCE, step, there)
        # one candidate (or none by itself) is where it is
        return b.coalesce((there, None), (step, None))

    def modifiers(self, step: int, np: NounPhrase, base: int) -> int:
        """Extremes, sides and ordinals among ``step`` (``base``: the phrase's candidates
        before relations)."""
        b = self.b
        if (
            np.extremes and np.extremes[0][0] is not Metric.Z and np.side in ("left", "right")
            and not np.side_negated and (np.ordinal or 1) == 1 and not b.at_most_one(step)
        ):  # fmt: skip
            # "the tall lamp on the left", "the larger pillow on the far right": of those
            # on that side, the tallest (largest)
            # "at the back on the left": of those on the left, the farthest ahead
            return self._extreme(self._side_half(step, np.side), *np.extremes[0], seen=step)
        if np.extremes and not b.at_most_one(step):
            metric, direction = np.extremes[0]
            if metric is not Metric.Z or np.side not in ("left", "right"):
                step = self._extreme(step, metric, direction)
            else:
                # "the upper left cabinet": of those on the highest level, the leftmost
                step = self._level(step, base, direction)
        if np.side in ("left", "right") and not b.at_most_one(step):
            side, nth = np.side, np.ordinal or 1
            if nth < -1:
                # "the second to last from the left": the second from the right
                side, nth = ("right" if side == "left" else "left"), -nth
            there = self._side(step, side, nth)
            # "not the door to your left": every other one
            step = b.add(Op.DIFFERENCE, step, there) if np.side_negated else there
        elif np.side == "middle" and not b.at_most_one(step):
            # the middle of the row along the observer's left-right axis: "the middle one"
            # of five is the third from the left; of four, the second (the left of the two
            # middle ones: on the Nr3D / ScanRefer train samples as good as keeping both
            # for the tie-break is 2 worse on Nr3D)
            view = self._side_view(step)
            metric = Metric.RIGHTWARD if view is not None else Metric.X
            middle = b.add(Op.MIDDLE, step, metric=metric, viewpoint=view)
            step = b.add(Op.ARGMIN, middle, metric=metric, viewpoint=view)
        return step

    def _side_with(self, step: int, group: int, np: NounPhrase) -> int | None:
        """Those of ``step`` on the side of the room where ``np.count`` of ``group``'s
        entities stand apart from the others ("on the side with two trash cans", "on the
        wall with two pictures"), as the ``k`` farthest ahead from the group's centre
        towards that side (:meth:`_group_side`). ``None`` (the relation says nothing) when
        the program does not know the entities, there are no more than ``count`` of them
        or every candidate is on that side."""
        n = np.count or 0
        ids, candidates = self.b.within(group), self.b.ids.get(step)
        if ids is None or candidates is None or not 0 < n < len(ids):
            self.b.note(f"'{n} {np.text}' standing together: no such group; not used")
            return None
        view, cut = self._group_side(ids, n)
        ahead = [i for i in candidates if self._ahead(i, view) > cut]
        if not 0 < len(ahead) < len(candidates):
            return None
        self.b.note(f"where {n} {np.text} stand together: {len(ahead)} of {len(candidates)}")
        return self.b.add(Op.ARGMAX, step, metric=Metric.FORWARD, k=len(ahead), viewpoint=view)

    def _ahead(self, i: int, view: dict[str, list[float]]) -> float:
        """How far entity ``i`` lies ahead of ``view``'s eye, horizontally: the query
        language's ``forward``, as every executor computes it (the view's direction a unit
        vector)."""
        e, eye, to = self.ctx.by_id[i], view["eye"], view["target"]
        return metric_value(PY, "forward", e.centroid, e.bbox_min, e.bbox_max,
                            ((eye[0], eye[1]), (to[0], to[1])))  # fmt: skip

    def _group_side(self, ids: tuple[int, ...], n: int) -> tuple[dict[str, list[float]], float]:
        """Where ``n`` of the entities ``ids`` (more than ``n``) stand apart: a view from
        their centre towards those ``n`` and the least ``forward`` of that side. The ``n``
        at either end of the horizontal axis they spread most along, or of the one across
        it, whose gap to the rest is widest for their own extent along it (two doors in one
        wall, 1 m from a third round the corner: 0.8 m apart across the wall, 0 m deep)."""
        xy = [self.ctx.by_id[i].centroid[:2] for i in ids]
        cx, cy = sum(p[0] for p in xy) / len(xy), sum(p[1] for p in xy) / len(xy)
        sxx = sum((p[0] - cx) ** 2 for p in xy)
        syy = sum((p[1] - cy) ** 2 for p in xy)
        sxy = sum((p[0] - cx) * (p[1] - cy) for p in xy)
        angle = 0.5 * math.atan2(2.0 * sxy, sxx - syy)  # the axis they spread most along
        best: tuple[float, float, tuple[float, float]] | None = None  # score, cut, axis
        for ux, uy in ((math.cos(angle), math.sin(angle)), (-math.sin(angle), math.cos(angle))):
            for sign in (1.0, -1.0):
                ahead = sorted(sign * ((p[0] - cx) * ux + (p[1] - cy) * uy) for p in xy)
                gap, extent = ahead[-n] - ahead[-n - 1], ahead[-1] - ahead[-n]
                score = gap / (extent + GROUP_EXTENT)
                if best is None or score > best[0]:
                    best = (score, (ahead[-n] + ahead[-n - 1]) / 2, (sign * ux, sign * uy))
        assert best is not None
        _, cut, (ax, ay) = best
        z = float(self.ctx.centre[2])
        return {"eye": [cx, cy, z], "target": [cx + ax, cy + ay, z]}, cut

    def _extreme(self, step: int, metric: Metric, direction: Op, seen: int | None = None) -> int:
        """The ``k`` of ``step`` with the least (``argmin``) or most ``metric``; ``forward``
        ("at the back of the room") is seen from the side view of ``seen`` (``step`` when
        not given: :meth:`_side_view`), and without one (the observer in the middle of the
        candidates) says nothing."""
        if metric is not Metric.FORWARD:
            return self.b.add(direction, step, metric=metric, k=self.k)
        view = self._side_view(step if seen is None else seen)
        if view is None:
            return step
        return self.b.add(direction, step, metric=metric, k=self.k, viewpoint=view)

    def _level(self, step: int, base: int, direction: Op) -> int:
        """Those of ``step`` on the highest (``argmax``) or lowest level of the phrase's
        candidates (``base``): the top one by centroid height and those next below it
        (above it) whose box spans its centroid's height or whose centroid its box spans
        (the upper cabinets of a kitchen, the books of one shelf), as the ``k`` highest
        (lowest); all of ``step`` when none of them is on it."""
        b = self.b
        ids = b.ids[base]
        if not ids:
            return step
        sign = -1.0 if direction is Op.ARGMAX else 1.0
        order = sorted(ids, key=lambda i: sign * self.ctx.by_id[i].centroid[2])
        top = self.ctx.by_id[order[0]]
        k = 1
        for i in order[1:]:
            e = self.ctx.by_id[i]
            if not (
                e.bbox_min[2] <= top.centroid[2] <= e.bbox_max[2]
                or top.bbox_min[2] <= e.centroid[2] <= top.bbox_max[2]
            ):
                break
            k += 1
        if k == len(ids):
            return step
        level = b.add(direction, base, metric=Metric.Z, k=k)
        return b.coalesce((b.add(Op.INTERSECT, step, level), None), (step, None))

    def _side_view(self, step: int) -> dict[str, list[float]] | None:
        """Where the observer stands to tell left from right among the candidates: looking
        from the scene centre (or the viewpoint) at the candidates' centroid; ``None`` when
        the two are too close to give a direction. A viewpoint that stands (or looks)
        within :data:`MIDDLE` of the half diagonal of where the observer looks from (at)
        gives no direction of its own ("sitting at the chair in the centre of the room"):
        the scene centre looking at the candidates instead."""
        target = self._mean_centroid(self.b.within(step))
        if target is None:
            return None
        eye = list(self.ctx.centre)
        ins = self.instruction
        if ins.viewpoint is not None:
            where = self._centroid_of(ins.viewpoint)
            if where is not None:
                seen_from = self._observer() or eye
                near = max(MIN_VIEW_DISTANCE, MIDDLE * self.ctx.half_diagonal)
                if math.dist(where[:2], seen_from[:2]) >= near:
                    eye, target = (where, seen_from) if ins.standing_at else (seen_from, where)
        if math.hypot(target[0] - eye[0], target[1] - eye[1]) < MIN_VIEW_DISTANCE:
            return None
        return {"eye": eye, "target": target}

    def _toward(
        self, step: int, side: str, k: int = 1, view: dict[str, list[float]] | None = None
    ) -> int:
        """The ``k`` candidates at ``step`` nearest the observer's ``side`` (``rightward``
        seen from ``view``, :meth:`_side_view`; without a direction, along ``x``)."""
        return self.b.add(Op.ARGMAX if side == "right" else Op.ARGMIN, step,
                          metric=Metric.RIGHTWARD if view is not None else Metric.X,
                          k=k if k > 1 else None, viewpoint=view)  # fmt: skip

    def _side_half(self, step: int, side: str) -> int:
        """The half of the candidates at ``step`` nearest the observer's ``side`` (of a
        number the program does not know yet, as after a relation, the two nearest)."""
        n = len(self.b.ids[step]) if step in self.b.ids else 0
        return self._toward(step, side, max(2, (n + 1) // 2), self._side_view(step))

    def _side(self, step: int, side: str, nth: int) -> int:
        """The ``nth`` candidate from the observer's ``side`` (:meth:`_toward`)."""
        view = self._side_view(step)
        if nth <= 1:
            return self._toward(step, side, self.count, view)
        upto, before = self._toward(step, side, nth, view), self._toward(step, side, nth - 1, view)
        return self.b.add(Op.DIFFERENCE, upto, before)
