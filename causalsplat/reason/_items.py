"""Tokens to items: noun phrases, relation cues, modifiers, negations, conjunctions.

One left-to-right pass. At each token the longest relation cue wins, then the longest
phrase naming a scene category (or a generic word: "one", "thing", "what"), then a
modifier (colour or stored attribute value, size/height word, side word, ordinal), then
a pronoun pointing back ("it", "its top"), then any other noun WordNet knows (an anchor
the scene may not hold). Modifiers right before a noun phrase belong to it; the others
("the chair on the left", "the one that is the largest") stand alone and belong to the
target.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from causalsplat.colors import SHADES, is_color_word
from causalsplat.reason import _grammar as g
from causalsplat.reason._mentions import (
    CategoryIndex,
    Mention,
    colour_word,
    foreign_at,
    may_modify,
    mention_at,
)
from causalsplat.reason._text import ORDINALS, number_word
from queries import Metric, Op

#: Side cues: "on the left" (no "of" after it) is a modifier, not a relation.
_SIDE_CUES = {"side_left": "left", "side_right": "right", "side_middle": "middle"}
#: Place cues: where in the room ("in the corner", "in the middle of the room") or apart
#: from the others of its kind ("by itself") a thing stands; modifiers of the target.
_PLACE_CUES = {"place_corner": "corner", "place_centre": "centre", "place_alone": "alone"}
#: Depth cues: "at the back of the room", "in the front left": the farthest or nearest ahead
#: of the observer (``forward``), a modifier of the target.
_DEPTH_CUES = {"depth_back": "back", "depth_front": "front"}
#: Depth words -> how they rank (``forward``: how far ahead of the observer).
_DEPTHS: dict[str, tuple[Metric, Op]] = {
    "back": (Metric.FORWARD, Op.ARGMAX),
    "rear": (Metric.FORWARD, Op.ARGMAX),
    "front": (Metric.FORWARD, Op.ARGMIN),
}
#: Nouns of position that, right before a noun, single out the highest or lowest of its kind.
_POSITION_ADJECTIVES = {"top": "highest", "bottom": "lowest"}
#: Surfaces of a room that say, as "floor to ceiling" or "wall to wall", how far a thing
#: reaches.
_SURFACES = frozenset({"floor", "ceiling", "wall", "roof"})
#: Words after a shade that make it the thing's lightness ("dark-coloured", "light toned").
_COLOURED = frozenset({"colored", "coloured", "color", "colour", "toned", "tone", "hued"})
#: Shade words that name a lightness by themselves ("the dark couch", "it is pale"):
#: "light" is also a thing, "deep" a depth; "lighter" and the superlatives compare.
_LONE_SHADES = frozenset({"dark", "darker", "darkest", "lighter", "lightest", "pale"})
#: Nouns the scene holds no entity for (places and people) whose modifiers describe them,
#: never the target: "the pillow in the dark corner", "a monitor in a dark room", "the bin
#: near the tall man"; and "in <colour>" after one of them is what they wear ("the chair
#: by the person in blue"). Parts are not among them: "a chair with a black back" is a
#: black chair as much as anything.
_OWN_MODIFIERS = frozenset({"corner", "room", "area", "spot", "place", "space", "person",
                            "people", "man", "woman", "guy", "girl", "boy", "men",
                            "women"})  # fmt: skip


@dataclass(frozen=True, slots=True)
class Modifier:
    """``kind`` is ``attribute`` (``value`` a word), ``extreme`` (``value`` the word,
    ``metric`` and ``direction`` what it ranks by), ``side`` (``value`` left/right/middle),
    ``place`` (``value`` corner/centre/alone) or ``ordinal`` (``number``); ``negated``:
    not there, or not that ("not in the corner", "not black")."""

    kind: str
    value: str = ""
    direction: Op | None = None
    metric: Metric | None = None
    number: int = 0
    negated: bool = False


@dataclass(frozen=True, slots=True)
class Item:
    """One item over tokens ``[start, end)``; exactly one of its fields is set."""

    start: int
    end: int
    np: object | None = None  # a parse.NounPhrase (kept untyped to avoid an import cycle)
    cue: g.Cue | None = None
    mod: Modifier | None = None
    negation: bool = False
    conjunction: bool = False
    back_reference: bool = False
    separator: bool = False


def _modifier(word: str, index: CategoryIndex) -> Modifier | None:
    if word in g.EXTREMES:
        metric, direction = g.EXTREMES[word]
        return Modifier("extreme", word, direction=direction, metric=metric)
    if word in g.SIDES:
        return Modifier("side", g.SIDES[word])
    if word in ORDINALS:
        return Modifier("ordinal", number=ORDINALS[word])
    if word in ("last", "final"):
        return Modifier("ordinal", number=-1)
    if word in index.attribute_words or colour_word(index.lexicon, word):
        return Modifier("attribute", word)
    return None


def describes(word: str, index: CategoryIndex) -> bool:
    """Whether ``word`` is an adjective of appearance, shape or size ("brown", "round",
    "big"), the words a list of adjectives is made of ("the big, brown, round table")."""
    mod = _modifier(word, index)
    return mod is not None and mod.kind in ("attribute", "extreme")


def _shade_at(tokens: tuple[str, ...], i: int) -> tuple[str, int] | None:
    """A shade word and what it qualifies, as one attribute and where it ends: "dark
    brown" (a shaded colour), "light coloured", "the light one" and "the dark couch" (a
    lightness)."""
    word = tokens[i]
    if word not in SHADES:
        return None
    after = tokens[i + 1] if i + 1 < len(tokens) else ""
    if is_color_word(after):
        return f"{word} {after}", i + 2
    if after in _COLOURED:
        return word, i + 2
    if after in ("one", "ones"):
        return word, i + 1
    if word in _LONE_SHADES:
        return word, i + 1
    return None


#: Verbs saying which way a thing faces ("a chair facing left", "it faces the right"), or
#: which way one goes ("turn left and the radiator is ...").
_FACING = frozenset({"facing", "faces", "faced", "face", "turned", "pointing", "points",
                     "oriented", "angled", "turn", "turns", "turning", "go", "walk",
                     "head", "veer"})  # fmt: skip


def _orientation_end(tokens: tuple[str, ...], i: int) -> int | None:
    """Where "facing (up / down and) (to / towards) (the) left / right (side)" ends when it
    starts at ``i``: the way a thing faces (or one goes), which no stored relation or
    attribute holds."""
    if tokens[i] not in _FACING:
        return None
    j = i + 1
    for optional in (("up", "down", "forward", "away", "out"), ("and",), ("to", "towards",
                     "toward"), ("the",)):  # fmt: skip
        if j < len(tokens) and tokens[j] in optional:
            j += 1
    if j >= len(tokens) or tokens[j] not in ("left", "right"):
        return None
    j += 1
    if j < len(tokens) and tokens[j] == "side":
        j += 1
    return None if j < len(tokens) and tokens[j] == "of" else j


def _than_the_other(tokens: tuple[str, ...], i: int) -> int | None:
    """Where "than the other (one / ones / two)" or "than the others" ends when it starts at
    ``i``: the other candidates a comparison is made with, never an anchor."""
    if tokens[i] != "than":
        return None
    j = i + 1
    if j < len(tokens) and tokens[j] in ("the", "that", "those", "any", "all"):
        j += 1
    if j < len(tokens) and tokens[j] == "others":
        return j + 1
    if j >= len(tokens) or tokens[j] != "other":
        return None
    j += 1
    if j < len(tokens) and tokens[j] in ("one", "ones", "two", "three", "four"):
        j += 1
    return j


#: Nouns of a group of like things ("the row of chairs").
_GROUPS = frozenset({"line", "row", "group", "set", "cluster", "bunch", "series", "column",
                     "collection", "pile", "stack", "pair", "couple"})  # fmt: skip
#: Group nouns that say how many: two.
_PAIRS = frozenset({"pair", "couple"})


def _group_of(tokens: tuple[str, ...], i: int) -> bool:
    """Whether "in / of / from / among the <group> of" starts at ``i``: the target is one of
    the group, so next to others of it ("the farthest to the left in the line of chairs")."""
    return (
        i + 3 < len(tokens)
        and tokens[i] in ("in", "of", "from", "among", "within")
        and tokens[i + 1] in ("the", "a", "this", "that")
        and tokens[i + 2] in _GROUPS
        and tokens[i + 3] == "of"
    )


def _told_to_look(tokens: tuple[str, ...], i: int) -> bool:
    """Whether ``tokens[i]`` is the "at" of a sentence that opens by telling one to look at
    something ("look at the picture above the seat", "please look at the lamp ..."): what
    is looked at is what is sought, not where it is.

    >>> _told_to_look(tuple("look at the picture above the seat".split()), 1)
    True
    >>> _told_to_look(tuple("the cup at the sink".split()), 2)
    False
    """
    if tokens[i] != "at" or i == 0 or tokens[i - 1] != "look":
        return False
    return i == 1 or tokens[i - 2] in (".", ",", "please", "then", "now", "and", "just")


#: Nouns for things piled on each other ("on top of the stack": the highest of them).
_HEAPS = frozenset({"stack", "pile", "heap"})
#: Words that place a thing above or below others ("under all the other towels").
_BELOW_WORDS = frozenset({"under", "below", "beneath", "underneath"})
_ABOVE_WORDS = frozenset({"above", "over", "atop"})


def _heap_position(tokens: tuple[str, ...], i: int) -> tuple[int, str] | None:
    """Where a place in a pile, or over or under all the others, ends, and the height word it
    means (``"highest"`` or ``"lowest"``), when one starts at ``i``: "on (the) top of the
    stack", "at the bottom of the pile", "under all the other towels", "above all the
    rest". The pile is the target's own kind, so the place picks the highest or the lowest
    of them; ``None`` otherwise.

    >>> _heap_position(tuple("the towel at the bottom of the pile".split()), 2)
    (8, 'lowest')
    >>> _heap_position(tuple("the towel under all the other towels".split()), 2)
    (7, 'lowest')
    >>> _heap_position(tuple("the towel under the sink".split()), 2) is None
    True
    """
    n = len(tokens)
    j = i
    if tokens[j] in ("on", "at", "in") and j + 1 < n:
        j += 1
        if tokens[j] == "the" and j + 1 < n:
            j += 1
        if tokens[j] in ("top", "bottom") and j + 1 < n and tokens[j + 1] == "of":
            word = "highest" if tokens[j] == "top" else "lowest"
            k = j + 2
            while k < n and tokens[k] in ("the", "a", "this", "that", "their", "its"):
                k += 1
            if k < n and tokens[k] in _HEAPS:
                return k + 1, word
        return None
    first = tokens[j]
    if first not in _BELOW_WORDS | _ABOVE_WORDS:
        return None
    word = "lowest" if first in _BELOW_WORDS else "highest"
    k = j + 1
    if k >= n or tokens[k] != "all":
        return None
    k += 1
    if k < n and tokens[k] == "of":
        k += 1
    if k < n and tokens[k] == "the":
        k += 1
    if k < n and tokens[k] in ("others", "rest"):
        return k + 1, word
    if k < n and tokens[k] == "other":
        # "the other towels", "the other ones": the target's kind named again
        k += 1
        if k < n and tokens[k].isalpha() and tokens[k] not in g.CLOSED_CLASS:
            k += 1
        return k, word
    return None


def _introduces(
    index: CategoryIndex, tokens: tuple[str, ...], i: int, earlier: tuple[str, ...]
) -> bool:
    """Whether a noun phrase starts at ``i`` whose head noun ``earlier`` does not hold."""
    mention = mention_at(index, tokens, i) if i < len(tokens) else None
    if mention is None:
        return False
    lemma = index.lexicon.lemma
    head = lemma(tokens[mention.end - 1])
    return all(lemma(t) != head for t in earlier)


def _noun_phrase(mention: object, mods: list[Modifier]) -> object:
    from causalsplat.reason.parse import NounPhrase

    return NounPhrase(
        mention,  # type: ignore[arg-type]
        attributes=tuple(m.value for m in mods if m.kind == "attribute"),
        extremes=tuple(
            (m.metric, m.direction) for m in mods if m.kind == "extreme" and not m.negated
        ),
        not_extremes=tuple(
            (m.metric, m.direction) for m in mods if m.kind == "extreme" and m.negated
        ),
        side=next((m.value for m in mods if m.kind == "side"), None),
        place=next((m.value for m in mods if m.kind == "place"), None),
        place_negated=any(m.negated for m in mods if m.kind == "place"),
        side_negated=any(m.negated for m in mods if m.kind == "side"),
        ordinal=next((m.number for m in mods if m.kind == "ordinal"), None),
    )


def _mods_of(np: object) -> list[Modifier]:
    out = [Modifier("attribute", a) for a in getattr(np, "attributes", ())]
    out += [Modifier("extreme", metric=m, direction=d) for m, d in getattr(np, "extremes", ())]
    return out


def _compound(
    items: list[Item], tokens: tuple[str, ...], index: CategoryIndex, mention: Mention,
    mods: list[Modifier], i: int,
) -> list[Modifier]:  # fmt: skip
    """Join the noun phrases right before the head ``mention`` at ``i`` into it, across at
    most two modifier words and no pending modifier: a noun compound ("bathroom sink",
    "wall portrait picture"), whose last noun is the head; never a word for any entity
    after a noun ("the door which"). Pops them from ``items``; returns the head's
    modifiers, theirs first."""
    start = i
    pending = bool(mods)
    while (
        items
        and items[-1].np is not None
        and not mention.generic
        and (
            items[-1].end == start
            or (
                0 < start - items[-1].end <= 2
                and all(may_modify(index.lexicon, t) for t in tokens[items[-1].end : start])
                and not pending
            )
        )
    ):
        previous = items.pop()
        mods = [*_mods_of(previous.np), *mods]
        start = previous.start
    return mods


#: Words after "from" that say which end a count starts at, not what it is counted from.
_COUNT_STARTS = frozenset({"left", "right", "top", "bottom", "end", "front", "back", "middle",
                           "center", "centre", "far", "other", "side", "near", "each",
                           "either", "your", "my", "our", "here", "there", "this", "north",
                           "south", "east", "west", "northeast", "northwest", "southeast",
                           "southwest", "northern", "southern", "eastern", "western"})  # fmt: skip


#: Words that count from the far end ("the last one", "the next to last stool").
_LAST = frozenset({"last", "final", "penultimate"})


def _from_last(tokens: tuple[str, ...], i: int) -> tuple[int, int] | None:
    """``(n, end)`` when the words from ``i`` count ``n`` from the far end: "penultimate",
    "next to last", "second to last", "second from last", "second last", "last but one"
    (2), "third to last" (3); else ``None``.

    >>> _from_last(("the", "next", "to", "last", "stool"), 1)
    (2, 4)
    >>> _from_last(("the", "stool", "next", "to", "the", "door"), 2) is None
    True
    """
    t = tokens[i]
    if t == "penultimate":
        return 2, i + 1
    after = tokens[i + 1 : i + 3]
    if t == "last" and after == ("but", "one"):
        return 2, i + 3
    n = 2 if t == "next" else ORDINALS.get(t, 0)
    if n < 2:
        return None
    if after in (("to", "last"), ("from", "last"), ("from", "the")) and (
        after[1] == "last" or tokens[i + 3 : i + 4] == ("last",)
    ):
        return (n, i + 3) if after[1] == "last" else (n, i + 4)
    if t != "next" and after[:1] == ("last",):
        return n, i + 2
    return None


def _counted_from(tokens: tuple[str, ...], i: int) -> bool:
    """Whether ``tokens[i]`` is the "from" of a count from a thing: "the second stool from
    the window", "the 2nd desk from the door" (the second closest to it), not from an end
    or side ("third from the left", "second from the top") nor from a place one comes
    from ("the first chair from your left").

    >>> _counted_from(("the", "second", "stool", "from", "the", "window"), 3)
    True
    >>> _counted_from(("the", "second", "from", "the", "left"), 2)
    False
    """
    before = tokens[max(0, i - 4) : i]
    if tokens[i] != "from" or not any(t in ORDINALS or t in _LAST for t in before):
        return False
    j = i + 1
    while j < len(tokens) and tokens[j] in ("the", "a", "an"):
        j += 1
    return j < len(tokens) and tokens[j].isalpha() and tokens[j] not in _COUNT_STARTS


def read_items(
    tokens: tuple[str, ...], index: CategoryIndex, before: tuple[str, ...] = ()
) -> list[Item]:
    """The items of ``tokens`` (module docstring); ``before``: the tokens said before them
    (a viewpoint clause), which "this" may point back to."""
    joined = " ".join(tokens)
    offsets: list[int] = []
    pos = 0
    for t in tokens:
        offsets.append(pos)
        pos += len(t) + 1
    items: list[Item] = []
    pending: list[tuple[int, Modifier]] = []

    def flush() -> None:
        for at, mod in pending:
            items.append(Item(at, at + 1, mod=mod))
        pending.clear()

    i = 0
    while i < len(tokens):
        t = tokens[i]
        if t in (",", ".", "?"):
            flush()
            items.append(Item(i, i + 1, separator=True))
            i += 1
            continue
        if t == "without":
            flush()
            items.append(Item(i, i + 1, negation=True))
            items.append(Item(i, i + 1, cue=g.Cue("with", i, i + 1)))
            i += 1
            continue
        if t in g.NEGATIONS:
            items.append(Item(i, i + 1, negation=True))
            i += 1
            continue
        excluding = _exclusion_at(tokens, i)
        if excluding:
            # "every stool but the one by the window", "the chairs other than the ones at
            # the desk": what follows is left out, as after "except"
            items.append(Item(i, i + excluding, negation=True))
            i += excluding
            continue
        if (
            t in ("and", "or", "&")
            and pending
            and pending[-1][1].kind == "attribute"
            and i + 1 < len(tokens)
            and (
                colour_word(index.lexicon, tokens[i + 1])
                or _adjective_of_next_noun(index, tokens, i + 1)
            )
        ):
            # "a blue and grey item": both colours of the one item; "the white and open
            # door": one door, white and open
            i += 1
            continue
        if t in ("and", "or", "&"):
            flush()
            items.append(Item(i, i + 1, conjunction=True))
            i += 1
            continue
        turned = _orientation_end(tokens, i)
        if turned is not None:
            i = turned  # "a chair facing left": which way it faces, not where it stands
            continue
        other = _than_the_other(tokens, i)
        if other is not None:
            i = other  # "closer to the door than the other one": the door is the anchor
            continue
        if (
            t in _SURFACES
            and i + 2 < len(tokens)
            and tokens[i + 1] == "to"
            and tokens[i + 2] in _SURFACES
        ):
            i += 3  # "floor to ceiling curtains", "wall-to-wall carpet": how far they reach
            continue
        if tokens[i : i + 3] == ("side", "by", "side"):
            i += 3  # "the two side-by-side doors": how they stand, no "by" of a relation
            continue
        if _told_to_look(tokens, i):
            i += 1  # "look at the picture above the seat": the picture is what is sought
            continue
        heap = _heap_position(tokens, i)
        if heap is not None:
            # "on top of the pile", "under all the other towels": the highest or lowest
            flush()
            metric, direction = g.EXTREMES[heap[1]]
            items.append(Item(i, heap[0], mod=Modifier("extreme", heap[1], direction=direction,
                                                       metric=metric)))  # fmt: skip
            i = heap[0]
            continue
        if _group_of(tokens, i):
            flush()
            if i + 4 < len(tokens) and number_word(tokens[i + 4]) > 1:
                # "in the cluster of three stools": one of the three that stand together
                items.append(Item(i, i + 5, cue=g.Cue("side_with", i, i + 5)))
                i += 5
            elif tokens[i + 2] in _PAIRS:
                # "the left one of the pair of chairs": of the two that stand together
                items.append(Item(i, i + 4, cue=g.Cue("side_with", i, i + 4)))
                i += 4
            else:
                # "in the row of shoes": one of them, beside the others, not inside them
                items.append(Item(i, i + 4, cue=g.Cue("near", i, i + 4)))
                i += 4
            continue
        if (
            t in _DEPTHS
            and i > 0
            and tokens[i - 1] == "the"
            and tokens[i + 1 : i + 2] in (("left",), ("right",))
        ):
            # "the back right monitor", "the front left one": ahead or near, then the side
            flush()
            items.append(Item(i, i + 1, mod=_side_or_depth(t)))
            i += 1
            continue
        if (
            t in _POSITION_ADJECTIVES
            and i + 1 < len(tokens)
            and (
                tokens[i + 1] in ("left", "right")
                or tokens[i + 1] in g.LEVELS
                or mention_at(index, tokens, i + 1)
            )
        ):
            # a position word used as an adjective: "the bottom shelf", "the top picture",
            # before a level even where the scene has no shelves ("on the top shelf"); "the
            # top left", "on the bottom right": the highest or lowest of them, and of those
            # the leftmost or rightmost (a position along two axes)
            metric, direction = g.EXTREMES[_POSITION_ADJECTIVES[t]]
            pending.append((i, Modifier("extreme", t, direction=direction, metric=metric)))
            i += 1
            continue
        from_last = _from_last(tokens, i)
        if from_last is not None:
            # "the next to last stool", "the penultimate one": counted from the other end
            flush()
            items.append(Item(i, from_last[1], mod=Modifier("ordinal", number=-from_last[0])))
            i = from_last[1]
            continue
        if _counted_from(tokens, i):
            # "the second stool from the window": the second closest to it; "the last
            # (next to last) stool from the window": the (second) farthest
            flush()
            kind = "farthest" if _LAST & set(tokens[max(0, i - 4) : i]) else "closest"
            items.append(Item(i, i + 1, cue=g.Cue(kind, i, i + 1)))
            i += 1
            continue
        cue = g.find_cue(tokens, tuple(offsets), joined, i)
        if (
            cue is not None
            and cue.kind in _DEPTH_CUES
            and cue.end < len(tokens)
            and (mention_at(index, tokens, cue.end) or foreign_at(index, tokens, cue.end))
        ):
            # "at the back wall", "in the front row of chairs": the word is the noun's
            cue = g.find_cue(tokens, tuple(offsets), joined, i, skip=frozenset(_DEPTH_CUES))
        worn = None if cue is None or cue.kind != "inside" else _worn_end(tokens, index, i, cue.end)
        if worn is not None:
            i = worn  # "the person in blue": theirs
            continue
        if cue is not None:
            flush()
            if cue.kind in _SIDE_CUES:
                items.append(Item(i, cue.end, mod=Modifier("side", _SIDE_CUES[cue.kind])))
            elif cue.kind in _PLACE_CUES or cue.kind in _DEPTH_CUES:
                if cue.kind in _PLACE_CUES:
                    items.append(Item(i, cue.end, mod=Modifier("place", _PLACE_CUES[cue.kind])))
                    said = _SIDE_OR_DEPTH
                else:
                    # "at the far end of the room" names no depth word
                    items.append(Item(i, cue.end, mod=_side_or_depth(_DEPTH_CUES[cue.kind])))
                    said = _SIDES
                # "in the back right corner": the corner on the right, at the back; "at
                # the back left of the room": the back one on the left
                items += [Item(k, k + 1, mod=_side_or_depth(tokens[k]))
                          for k in range(i, cue.end) if tokens[k] in said]  # fmt: skip
            else:
                items.append(Item(i, cue.end, cue=cue))
            i = cue.end
            continue
        # a demonstrative right before a noun is its determiner ("this cabinet"), unless the
        # noun was said before ("facing the couch, the lamp right of this couch")
        introduces = t == "this" and _introduces(index, tokens, i + 1, (*before, *tokens[:i]))
        if t in g.DETERMINERS and (t not in ("that", "this", "its", "their") or introduces):
            i += 1
            continue
        shade = _shade_at(tokens, i)
        if shade is not None:
            pending.append((i, Modifier("attribute", shade[0])))
            i = shade[1]
            continue
        located = _room_modified(index, tokens, i)
        if located is not None:
            # "the bathroom door": the door closest to the bathroom
            room, head = located
            mods = [m for _, m in pending]
            mods = _compound(items, tokens, index, head, mods, i)
            items.append(Item(i, head.end, np=_noun_phrase(head, mods)))
            items.append(Item(i, i + 1, cue=g.Cue("closest", i, i + 1)))
            items.append(Item(i, i + 1, np=_noun_phrase(room, [])))
            pending.clear()
            i = head.end
            continue
        mention = mention_at(index, tokens, i)
        if mention is not None:
            mods = _compound(items, tokens, index, mention, [m for _, m in pending], i)
            items.append(Item(i, mention.end, np=_noun_phrase(mention, mods)))
            pending.clear()
            i = mention.end
            continue
        mod = _modifier(t, index)
        if mod is not None and mod.kind == "attribute":
            compound = foreign_at(index, tokens, i)
            if (
                compound is not None
                and compound.end - compound.start > 1
                and not any(mention_at(index, tokens, j) for j in range(i + 1, compound.end))
            ):
                # "the coffee maker": a thing, not a coffee-coloured maker; "the blue book"
                # (a WordNet compound too) is a book that is blue when books are here
                mod = None
        if mod is not None:
            pending.append((i, mod))
            i += 1
            continue
        if t in g.PRONOUNS or t in g.BACK_REFERENCES:
            flush()
            items.append(Item(i, i + 1, back_reference=True))
            i += 1
            continue
        foreign = foreign_at(index, tokens, i)
        if foreign is not None:
            mods = [m for _, m in pending]
            if foreign.categories:
                # "the wall mounted bookshelf" where shelves are here: a shelf
                mods = _compound(items, tokens, index, foreign, mods, i)
            items.append(Item(i, foreign.end, np=_noun_phrase(foreign, mods)))
            pending.clear()
            i = foreign.end
            continue
        if t in _OWN_MODIFIERS:
            # "in the dark corner", "in a small room": the corner is dark, the room small;
            # "in the upper corner" still says where the target is
            pending[:] = [(at, m) for at, m in pending if not _its_own(m)]
        i += 1
    flush()
    return items


def _exclusion_at(tokens: tuple[str, ...], i: int) -> int:
    """Length of an exclusion at ``tokens[i]`` that reads as "except": "but" before "the
    one(s)" or "those", or "other than" (0 when there is none).

    >>> _exclusion_at(("every", "stool", "but", "the", "one", "by", "the", "door"), 2)
    1
    >>> _exclusion_at(("it", "is", "brown", "but", "the", "seat", "is", "red"), 3)
    0
    """
    after = tokens[i + 1 : i + 3]
    if tokens[i] == "but" and (
        after[:1] == ("those",) or after in (("the", "one"), ("the", "ones"))
    ):
        return 1
    return 2 if tokens[i] == "other" and after[:1] == ("than",) else 0


def _adjective_of_next_noun(index: CategoryIndex, tokens: tuple[str, ...], i: int) -> bool:
    """Whether ``tokens[i]`` is a word before a noun naming a scene category right after
    it ("open" in "the white and open door"), not a noun or a clause of its own."""
    return (
        i + 1 < len(tokens)
        and may_modify(index.lexicon, tokens[i])
        and mention_at(index, tokens, i) is None
        and foreign_at(index, tokens, i) is None
        and mention_at(index, tokens, i + 1) is not None
    )


def _room_modified(
    index: CategoryIndex, tokens: tuple[str, ...], i: int
) -> tuple[Mention, Mention] | None:
    """A room word at ``i`` right before a noun naming a scene category, where the two do
    not name one together (:data:`~causalsplat.reason._grammar.ROOM_MODIFIERS`): the room
    says where the thing is ("the bathroom door"), not what it is: "the kitchen cabinets",
    "the bathroom stall door" stay what the scene calls them.
    Returns the room (resolved as an anchor phrase, possibly to nothing) and the head."""
    if tokens[i] not in g.ROOM_MODIFIERS or i + 1 >= len(tokens):
        return None
    whole = mention_at(index, tokens, i)
    head = mention_at(index, tokens, i + 1)
    if head is None or head.generic:
        return None
    if whole is not None and whole.end > i + 1:
        return None
    room = whole or foreign_at(index, (tokens[i],), 0) or Mention(0, 1, tokens[i], (), 0.0)
    return replace(room, start=i, end=i + 1), head


def _its_own(mod: Modifier) -> bool:
    """Whether a modifier before a place or a person describes it (a colour, a size), not
    where the target is (a height: "the upper corner")."""
    return mod.kind == "attribute" or (mod.kind == "extreme" and mod.metric is not Metric.Z)


def _worn_end(tokens: tuple[str, ...], index: CategoryIndex, i: int, end: int) -> int | None:
    """Where the attribute words end (a determiner before them allowed) when the "in" at
    ``i`` (its cue ending at ``end``) says what a person or place just named looks like:
    "the person in blue", "a man in a red shirt" is what he wears, not where the target
    is; ``None`` otherwise."""
    if i == 0 or tokens[i - 1] not in _OWN_MODIFIERS:
        return None
    j = end + 1 if end < len(tokens) and tokens[end] in g.DETERMINERS else end
    k = j
    while (
        k < len(tokens) and (m := _modifier(tokens[k], index)) is not None and m.kind == "attribute"
    ):
        k += 1
    return k if k > j else None


#: Words inside a place or depth cue that say a side or a depth ("back left corner").
_SIDES = frozenset({"left", "right"})
_SIDE_OR_DEPTH = _SIDES | frozenset(_DEPTHS)


def _side_or_depth(word: str) -> Modifier:
    """The modifier a side word ("left") or depth word ("back") inside a cue says."""
    if word in _DEPTHS:
        metric, direction = _DEPTHS[word]
        return Modifier("extreme", word, direction=direction, metric=metric)
    return Modifier("side", g.SIDES[word])
