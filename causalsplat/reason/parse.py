"""Stage 1 of the offline reasoner: instruction parsing.

:func:`parse_instruction` reads an instruction into an :class:`Instruction`: what kind of
request it is (a referring expression, a question over a set, a count, a counterfactual,
an affordance request), the target noun phrase with its modifiers and the relations it
must satisfy (each with its anchor noun phrases), the viewpoint clause ("facing the
couch, ..."), and the words that describe an action for affordance matching. Nothing here
touches the graph's geometry: noun phrases are resolved to category names only.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass, field, replace

from causalsplat.colors import is_color_word
from causalsplat.reason import _grammar as g
from causalsplat.reason._conditions import (
    asks_what_follows,
    moves_away,
    split_carried,
    split_condition,
)
from causalsplat.reason._items import Item, Modifier, describes, read_items
from causalsplat.reason._mentions import NAMED, CategoryIndex, Mention, mention_at
from causalsplat.reason._spelling import correct
from causalsplat.reason._text import NUMBER_WORDS, number_word, tokenize
from causalsplat.reason.lexicon import Lexicon
from queries import Metric, Op


@dataclass(frozen=True, slots=True)
class NounPhrase:
    """A noun phrase: the entities it can name, narrowed by modifiers and relations.

    ``mention`` is ``None`` for "anything" (a wh-word or "something"); ``attributes`` are
    modifier words that may match stored attribute values ("black"); ``extremes`` are
    (metric, ``argmax``/``argmin``) from size, height and depth words; ``side`` is ``left`` /
    ``right`` / ``middle`` / ``top``; ``ordinal`` is 1 for "first", 2 for "second"...;
    ``place`` is where in the room it stands: ``corner`` (farthest from the scene centre),
    ``centre`` (closest to it) or ``alone`` (farthest from the others of its kind);
    ``place_negated``: not the one there ("not the one in the corner"); ``side_negated``:
    not the one on that side ("not the door to your left");
    ``not_attributes``: attribute words it does not have ("the chair that is not black",
    "the brown door, not the white one"); ``not_extremes``: superlatives it is not ("the
    stool that is not the tallest", "not at the front of the room"); ``count``: how many
    the target phrase asks for when it says a number ("the two stools closest to the
    window": 2), else ``None``.
    """

    mention: Mention | None
    attributes: tuple[str, ...] = ()
    not_attributes: tuple[str, ...] = ()
    extremes: tuple[tuple[Metric, Op], ...] = ()
    not_extremes: tuple[tuple[Metric, Op], ...] = ()
    side: str | None = None
    ordinal: int | None = None
    place: str | None = None
    place_negated: bool = False
    side_negated: bool = False
    constraints: tuple[Constraint, ...] = ()
    coordinated: tuple[NounPhrase, ...] = ()
    count: int | None = None

    @property
    def categories(self) -> tuple[str, ...]:
        return () if self.mention is None else self.mention.categories

    @property
    def is_any(self) -> bool:
        """Names any entity (no category): "what", "something", "the one"."""
        return self.mention is None or self.mention.generic

    @property
    def resolved(self) -> bool:
        """Names something the scene holds (a category, or any entity)."""
        return self.is_any or bool(self.categories)

    @property
    def text(self) -> str:
        words = [*self.attributes, "anything" if self.mention is None else self.mention.phrase]
        return " ".join(words)


@dataclass(frozen=True, slots=True)
class Constraint:
    """The target is ``kind`` (a relation kind of :mod:`._grammar`) of ``anchors``
    (two for ``between``); ``negated`` for "not ..."; ``span``: its tokens ``[start,
    end)``, the cue to the last anchor (in the tokens after the viewpoint clause); ``far``:
    the cue says how far ("to the far left of", "all the way to the right of")."""

    kind: str
    anchors: tuple[NounPhrase, ...]
    negated: bool = False
    span: tuple[int, int] = (0, 0)
    far: bool = False


@dataclass(frozen=True, slots=True)
class Instruction:
    """Stage 1's reading of an instruction.

    Attributes:
        text: the instruction.
        tokens: its tokens.
        kind: ``refer`` (one entity), ``set`` (every entity that fits), ``count``,
            ``exists``, ``counterfactual`` or ``action`` (affordance matching).
        target: the noun phrase asked about (``None`` only for counterfactuals).
        removed: for counterfactuals, the noun phrases removed.
        action: the words describing an action or need ("wash", "hands").
        viewpoint: the noun phrase of a viewpoint clause ("facing the couch").
        standing_at: the observer stands at the viewpoint entity (else looks at it).
        observer_at: where the observer stands while looking at the viewpoint entity
            ("standing at the door looking at the windows": the door), or ``None`` (the
            scene centre).
        closure: a counterfactual or set question over everything stacked, transitively.
        moved: a counterfactual that moves ``removed`` without taking it away ("if I lift
            the tray, what moves with it?"): what rests on it, transitively, goes along.
        purpose_start: index in ``main_tokens`` where the purpose clause of a need begins
            ("where can I | heat up soup"), or ``None``.
        main_tokens: the tokens without the viewpoint clause (set for needs).
        command: the need is said as a command ("store my dishes", "sit on the couch"):
            its purpose clause is the whole sentence.
        corrected: misspelt words read as another, ``(written, read)``
            (:mod:`~causalsplat.reason._spelling`); ``tokens`` hold the words as read.
    """

    text: str
    tokens: tuple[str, ...]
    kind: str
    target: NounPhrase | None
    removed: tuple[NounPhrase, ...] = ()
    action: tuple[str, ...] = ()
    viewpoint: NounPhrase | None = None
    standing_at: bool = False
    observer_at: NounPhrase | None = None
    closure: bool = False
    moved: bool = False
    notes: tuple[str, ...] = field(default=())
    purpose_start: int | None = None
    main_tokens: tuple[str, ...] = ()
    command: bool = False
    corrected: tuple[tuple[str, str], ...] = ()

    @property
    def is_intrinsic(self) -> bool:
        """No relation to another entity is involved (the method skips topology)."""
        target = self.target
        return (
            self.kind in ("refer", "set", "count", "exists")
            and target is not None
            and not target.constraints
            and self.viewpoint is None
        )


def parse_instruction(text: str, index: CategoryIndex) -> Instruction:
    """Stage 1 (module docstring)."""
    tokens, corrected = correct(
        tokenize(text), index.spelling_vocabulary, index.is_word, index.categories
    )
    tokens = others_as_ones(tokens, index)
    if corrected:
        return replace(_parse(text, tokens, index), corrected=corrected)
    return _parse(text, tokens, index)


def others_as_ones(tokens: tuple[str, ...], index: CategoryIndex) -> tuple[str, ...]:
    """``tokens`` with the noun that "the others" and "the other two" leave out said:
    "between the other two" is between the other two *ones* (of the target's kind), as
    "the others" are the other ones; a noun after the number keeps its place ("the other
    two doors")."""
    out: list[str] = []
    for i, t in enumerate(tokens):
        if t == "others":
            out += ["other", "ones"]
            continue
        out.append(t)
        counted = number_word(t) > 1  # not "the other one"
        if counted and i > 0 and tokens[i - 1] == "other":
            after = i + 1
            if after == len(tokens) or (
                mention_at(index, tokens, after) is None
                and not index.lexicon.has_noun(index.lexicon.lemma(tokens[after]))
            ):
                out.append("ones")
    return tuple(out)


def _parse(text: str, tokens: tuple[str, ...], index: CategoryIndex) -> Instruction:
    condition = split_condition(tokens)
    if condition is not None:
        return _counterfactual(text, tokens, condition, index)
    carried = split_carried(tokens)
    if carried is not None:
        # "if I lift the tray, what moves with it?": everything resting on it, transitively
        moved = _Reader(read_items(carried[0], index), None, carried[0]).read()
        return Instruction(text, tokens, "counterfactual", None, removed=_removed(moved),
                           closure=True, moved=True)  # fmt: skip
    view_tokens, main_tokens = _split_viewpoint(tokens, lambda w: describes(w, index))
    main_tokens = without_blocked_activity(main_tokens)
    view = _viewpoint(view_tokens, index)
    viewpoint, standing = view.entity, view.standing
    items = read_items(main_tokens, index, view_tokens)
    picked = _picked_clause(main_tokens, items)
    if picked is None:
        reader = _Reader(items, viewpoint, main_tokens)
    else:
        # "look for the bed. choose the pillow at its foot": the target is what is chosen;
        # what came before is context a pronoun may point back to
        before, main = main_tokens[:picked], main_tokens[picked:]
        reader = _Reader(read_items(main, index, (*view_tokens, *before)), viewpoint, main)
        reader.free = next(it.np for it in items if it.np is not None)  # type: ignore[assignment]
    target = reader.read()
    joined = " ".join(tokens)
    wh = bool(main_tokens) and (main_tokens[0] in g.WH_WORDS or joined.startswith("how many"))
    if viewpoint is not None and viewpoint.categories and not wh:
        if target is None:  # "facing the windows, left": one of the windows
            target = NounPhrase(mention=(view.shown or viewpoint).mention)
        elif target.mention is None or target.mention.phrase in ("one", "ones"):
            # "facing the chairs, choose the second from the left", "... the one on the
            # left": one of the chairs
            target = replace(target, mention=(view.shown or viewpoint).mention)
    falls = bool(g.FALL_TRIGGERS.search(joined))
    if (g.REMOVAL_TRIGGERS.search(joined) and (falls or _asks_consequence(tokens))) or (
        falls and target is not None and not target.is_any
    ):
        removed = _removed(target)
        return Instruction(text, tokens, "counterfactual", None, removed=removed,
                           closure=bool(g.CLOSURE_TRIGGERS.search(joined)))  # fmt: skip
    action = _action_words(main_tokens, items)
    purpose, fetch = _purpose(main_tokens)
    imperative = _imperative(main_tokens, index) if purpose is None else (None, False)
    kind_noun = False
    if purpose is None and (g.ACTION_TRIGGERS.search(joined) or imperative[0] is not None):
        # "I need a machine to dry my clothes": what is wanted is whatever does the purpose
        purpose = _kind_purpose(main_tokens, items, index.lexicon)
        kind_noun = purpose is not None
    command = False
    if purpose is None:
        purpose, fetch = imperative
        command = purpose is not None
        if fetch and (target is None or (target.is_any and target.mention is not None)):
            # "take the one on the left": a picking, read as the description it opens
            purpose, fetch, command = None, False, False
    wants = (
        g.ACTION_TRIGGERS.search(joined)
        or purpose is not None
        or any(g.state_at(main_tokens, i) for i in range(len(main_tokens)))
    )
    instrument = _instrument(target, purpose, main_tokens) if wants and not kind_noun else None
    if instrument is not None:
        target = instrument
    elif wants and (kind_noun or not _names_what_is_wanted(target, purpose, fetch)):
        if (
            kind_noun
            and target is not None
            and target.mention is not None
            and purpose is not None
            and target.mention.start < purpose
        ):
            # the kind noun says what sort of thing does it; the need decides which
            target = NounPhrase(None, constraints=target.constraints)
        target = _place_of_need(_anchor_of_need(target, items))
        return Instruction(text, tokens, "action", target, action=action, viewpoint=viewpoint,
                           standing_at=standing, observer_at=view.observer,
                           purpose_start=purpose,
                           main_tokens=main_tokens, command=command)  # fmt: skip
    if target is None:
        target = NounPhrase(None)
    elif not wh:
        target = _demonstrated(target, main_tokens, viewpoint)
    universal = any(t in _UNIVERSAL for t in main_tokens)
    if _unrestricted(target) and viewpoint is None and action and not universal:
        # "which thing needs watering?", "where can the baby play?": nothing but the rest
        # of the sentence says what is asked for; read as a need, never as everything
        return Instruction(text, tokens, "action", target, action=action,
                           purpose_start=purpose, main_tokens=main_tokens,
                           command=command)  # fmt: skip
    if joined.startswith("how many"):
        kind = "count"
    elif main_tokens[:2] in (("is", "there"), ("are", "there")):
        kind = "exists"
    elif (wh and _set_question(main_tokens, target)) or _quantified(main_tokens, target):
        kind = "set"
    else:
        kind = "refer"
        count = _count_of(main_tokens, target, index.lexicon)
        if count is not None:
            target = replace(target, count=count)
        target = _of_a_group(main_tokens, target, index.lexicon)
    closure = kind == "set" and bool(g.CLOSURE_TRIGGERS.search(joined))
    return Instruction(text, tokens, kind, target, viewpoint=viewpoint, standing_at=standing,
                       observer_at=view.observer,
                       closure=closure)  # fmt: skip


def without_blocked_activity(tokens: tuple[str, ...]) -> tuple[str, ...]:
    """``tokens`` without the activity a state is too much for ("it's too hot | to work in
    here", "too dark | for reading"): the need is to mend the state, and the activity's
    words would pull the answer towards it (the desk, not the fan). The clause boundary
    after it and what follows are kept.

    >>> without_blocked_activity(("it", "is", "too", "hot", "to", "work", "in", "here"))
    ('it', 'is', 'too', 'hot')
    >>> without_blocked_activity(("too", "dark", "to", "read", ",", "what", "can", "i", "do"))
    ('too', 'dark', ',', 'what', 'can', 'i', 'do')
    >>> without_blocked_activity(("keep", "it", "cold", "to", "serve"))
    ('keep', 'it', 'cold', 'to', 'serve')
    """
    for i in range(1, len(tokens) - 1):
        if tokens[i - 1] == "too" and tokens[i + 1] in ("to", "for") and g.state_at(tokens, i):
            end = next((j for j in range(i + 1, len(tokens)) if tokens[j] in (",", ".", "?")),
                       len(tokens))  # fmt: skip
            return (*tokens[: i + 1], *tokens[end:])
    return tokens


def _counterfactual(
    text: str,
    tokens: tuple[str, ...],
    condition: tuple[tuple[str, ...], tuple[str, ...]],
    index: CategoryIndex,
) -> Instruction:
    """A counterfactual whose condition clause was found (:mod:`._conditions`), in either
    order: what the condition removes, and whether the question asks for everything
    stacked on it."""
    removed_tokens, question = condition
    target = _Reader(read_items(removed_tokens, index), None, removed_tokens).read()
    closure = bool(g.CLOSURE_TRIGGERS.search(" ".join(question)))
    return Instruction(text, tokens, "counterfactual", None, removed=_removed(target),
                       closure=closure)  # fmt: skip


def _asks_consequence(tokens: tuple[str, ...]) -> bool:
    """Whether an instruction that removes something without a condition clause asks
    what follows ("remove the bed: what happens?", "take away the table, what is left
    standing?"); a description that only says something was pulled out ("the bookshelf
    that is pulled out", "the chair pulled out from the desk. which one is it?") asks
    nothing of the kind, unless it opens by telling to remove ("take away the table, what
    is on the floor?")."""
    return "?" in tokens and (asks_what_follows(tokens) or moves_away(tokens[0]))


def _unrestricted(target: NounPhrase) -> bool:
    """A phrase that names any entity and narrows it by nothing: no category, relation,
    attribute, superlative, side, ordinal or place ("what", "which thing", "something")."""
    return (
        target.is_any
        and not target.categories
        and not target.constraints
        and not target.attributes
        and not target.extremes
        and target.side is None
        and target.ordinal is None
        and target.place is None
    )


#: Words that ask for every entity that qualifies ("all the stools at the counter").
_UNIVERSAL = frozenset({"all", "every", "each", "everything", "both"})


def _quantified(tokens: tuple[str, ...], target: NounPhrase) -> bool:
    """Whether a universal quantifier governs the target: before its noun ("all the seats
    at the table", "every pillow on the bed"), or anywhere when the target is any entity
    ("everything on the desk")."""
    end = len(tokens) if target.is_any or target.mention is None else target.mention.start
    # "next to each other" says how they stand, not that every one is asked for
    return any(
        t in _UNIVERSAL and tokens[k : k + 2] != ("each", "other")
        for k, t in enumerate(tokens[:end])
    )


#: Lexicon score from which a noun names a scene category itself (its name, base form or
#: synonym), not only as its head noun ("machine" of "washing machine") or a hypernym.
_NAMES_ITSELF = 0.9
_INDEFINITE = frozenset({"a", "an", "some", "another"})


def _kind_purpose(tokens: tuple[str, ...], items: list[Item], lexicon: Lexicon) -> int | None:
    """Where the purpose clause begins in "a N to VERB ..." when N names no scene category
    itself, only a kind of thing ("I need a device to clean my clothes", "a machine to dry
    my clothes", "a tool to exercise with"): the purpose says which thing is wanted, as
    after "something to". A noun that names a category ("a towel to dry off") is itself
    the thing wanted; ``None`` then, and when there is no such frame."""
    named = {
        it.np.mention.end: it.np.mention.score
        for it in items
        if isinstance(it.np, NounPhrase) and it.np.mention is not None
        and it.np.mention.categories
    }  # fmt: skip
    for i in range(2, len(tokens) - 1):
        if tokens[i] != "to":
            continue
        # the noun phrase before "to": at most three words after an indefinite article
        opened = [k for k in range(max(0, i - 4), i - 1) if tokens[k] in _INDEFINITE]
        if not opened or not all(t.isalpha() for t in tokens[opened[-1] + 1 : i]):
            continue
        after = tokens[i + 1]
        if (
            after in g.DETERMINERS
            or after in g.PRONOUNS
            or not lexicon.verb_senses(lexicon.lemma(after, "v"))
        ):
            return None
        if named.get(i, 0.0) >= _NAMES_ITSELF:
            return None
        return i + 1
    return None


def _purpose(tokens: tuple[str, ...]) -> tuple[int | None, bool]:
    """Where the purpose clause of a need begins, and whether its verb is one of getting
    or finding ("where can I find a mug": the mug is the thing wanted)."""
    joined = " ".join(tokens)
    m = g.PURPOSE_FRAMES.search(joined)
    if m is None:
        return None, False
    start = len(joined[: m.end()].split())
    rest = [t for t in tokens[start:] if t not in ("me", "us", "to", "go", "and")]
    return start, bool(rest) and rest[0] in g.FETCH_VERBS


#: Words after an imperative's verb that show it is one ("store *my* dishes", "dry *the*
#: plates", "warm *up*"): what it acts on, or its particle.
_AFTER_IMPERATIVE = frozenset({"my", "your", "our", "his", "her", "their", "some", "a", "an",
                               "the", "this", "these", "those", "me", "us", "it", "them",
                               "myself", "yourself", "ourselves", "themselves",
                               "up", "down", "off", "out", "away"})  # fmt: skip
#: Prepositions after which a sentence's first word is a command's verb when it names no
#: object ("sit *on* the couch", "turn *on* the tv", "lie *in* bed"); a word that can name
#: one stays a noun ("light on the wall", "book on the shelf").
_AFTER_COMMAND_VERB = frozenset({"on", "in", "into", "onto", "at", "with", "under", "over",
                                 "by", "through", "against", "beside"})  # fmt: skip


#: Verbs among the grammar's function words that still open a command ("put my cup
#: down", "set an alarm", "do my laundry", "have a drink", "get water").
_COMMAND_FUNCTION_VERBS = frozenset({"put", "set", "do", "have", "get"})
#: Verbs of getting: a command with one asks for its object when the scene has it.
_GETTING = frozenset({"get", "grab", "fetch", "bring", "take", "have", "buy", "borrow"})
#: Verbs that take an adjective or participle after them ("keep food fresh", "stay
#: connected", "feel safe", "make sure"): any word may follow.
_COPULAR = frozenset({"keep", "stay", "remain", "feel", "make", "become"})


def _bare_object(tokens: tuple[str, ...], k: int, index: CategoryIndex) -> bool:
    """Whether ``tokens[k]`` is the bare noun a command acts on ("cook | pasta", "boil |
    water for tea"): a noun that names no scene category, alone or with the word before
    it ("trash can", "shower curtain" and "file cabinet" are things, not commands), and
    after which the sentence ends, says what for, or goes on with a preposition ("eat food
    from a bowl")."""
    word = tokens[k]
    lexicon = index.lexicon
    if not word.isalpha() or word in g.FUNCTION_WORDS or not lexicon.has_noun(lexicon.lemma(word)):
        return False
    if index.lookup((word,)) is not None or index.lookup(tokens[k - 1 : k + 1]) is not None:
        return False
    rest = [t for t in tokens[k + 1 :] if t.isalnum()]
    return not rest or rest[0] == "for" or rest[0] in _AFTER_COMMAND_VERB or rest[0] == "from"


def _manner(word: str, lexicon: Lexicon) -> bool:
    """An adverb of manner before a command's verb ("quickly heat up my food"): a word in
    -ly that WordNet knows as no noun and no verb."""
    return (len(word) > 4 and word.endswith("ly") and not lexicon.verb_senses(word)
            and not lexicon.has_noun(word))  # fmt: skip


def _imperative(tokens: tuple[str, ...], index: CategoryIndex) -> tuple[int | None, bool]:
    """Where a need said as a command begins ("store my dishes", "warm up the soup",
    "please dry my hair", "sit on the couch"), and whether its verb is one of getting
    ("get water", "have a drink"); ``(None, False)`` for anything else ("picture above the
    bed", "choose the chair on the left"). The sentence opens with a verb in its base form
    (after "please", an adverb of manner or "be able to") that names no scene category and
    is no picking, seeing or viewpoint verb ("choose", "locate", "facing"), followed by
    what it acts on, its particle, a preposition when the verb names no object at all
    ("sit on", but "light on the wall" is a thing), or anything when the verb takes an
    adjective ("keep food fresh", "stay connected"). Its purpose clause is the whole
    sentence: a command says what the speaker wants done, and is grounded as the same need
    said as a want ("I want to warm up the soup": the stove); when nothing here does it,
    what it acts on is the thing meant ("open the fridge", "make the bed":
    :meth:`Grounder.intent <causalsplat.reason.ground.Grounder.intent>`). A verb of getting
    asks for its object when the scene has it by name ("grab a towel": the towel), as a
    description does, and for what gives it otherwise ("get water": the faucet). What it
    acts on may be a bare noun when the command says nothing more (:func:`_bare_object`:
    "cook pasta", "boil water")."""
    lexicon = index.lexicon
    if not tokens:
        return None, False
    i = 1 if tokens[:1] == ("please",) or _manner(tokens[0], lexicon) else 0
    if tokens[i : i + 3] == ("be", "able", "to"):
        i += 3
    if len(tokens) < i + 2:
        return None, False
    verb = tokens[i]
    if (
        tokens[i + 1] not in _AFTER_IMPERATIVE
        and not _bare_object(tokens, i + 1, index)
        and (tokens[i + 1] not in _AFTER_COMMAND_VERB or lexicon.has_noun(lexicon.lemma(verb)))
        and not (verb in _COPULAR and tokens[i + 1].isalpha())
    ):
        return None, False
    getting = verb in _GETTING
    if getting and any(t in g.DEFINITE for t in tokens[i + 1 : i + 3]):
        # "bring me the cup", "get my phone": a definite object is one the speaker takes
        # to be here, asked for as a description asks ("get some water" asks what gives it)
        return None, False
    if (
        (verb in g.FUNCTION_WORDS and verb not in _COMMAND_FUNCTION_VERBS)
        or verb in g.VIEW_TRIGGERS
        or verb in g.WH_WORDS
        or verb in _PICKING
        or (verb in g.FETCH_VERBS and not getting)
        or verb in lexicon.colors
        or index.lookup((verb,)) is not None
        or not lexicon.verb_senses(verb)
        or lexicon.lemma(verb, "v") != verb
    ):
        return None, False
    return i, getting


def _names_what_is_wanted(target: NounPhrase | None, purpose: int | None, fetch: bool) -> bool:
    """The target noun names a scene category outright and is the thing wanted, not a word
    of the purpose ("I need a towel to dry off" names a towel; "where can I heat up a bowl
    of soup" does not name the bowl as the thing wanted)."""
    if target is None or target.is_any or target.mention is None:
        return False
    mention = target.mention
    if not mention.categories or mention.score < NAMED:
        return False
    return purpose is None or fetch or mention.start < purpose


#: Verbs of resting somewhere: what they are done "with" keeps one company ("sit with my
#: laptop" asks for a seat).
_POSTURE = frozenset({"sit", "lie", "lay", "rest", "relax", "sleep", "nap", "stand", "wait",
                      "lounge", "recline", "stay", "be"})  # fmt: skip


def _instrument(
    target: NounPhrase | None, purpose: int | None, tokens: tuple[str, ...]
) -> NounPhrase | None:
    """What the need is done with, when its purpose clause names it after "with" and
    nothing else here is asked for ("I need to decorate with plants", "decorate my home
    with plants": the home names nothing here): the thing wanted ("something to decorate
    with flowers" asks for the something)."""
    if target is None or not target.constraints:
        return None
    if target.mention is not None and (target.mention.categories or target.is_any):
        return None  # "I need a towel to dry off with": the towel; "something to ... with"
    first = target.constraints[0]
    if first.kind != "with" or first.negated or len(first.anchors) != 1:
        return None
    (np,) = first.anchors
    m = np.mention
    if m is None or np.is_any or not m.categories or m.score < NAMED:
        return None
    if purpose is None or first.span[0] < purpose or purpose >= len(tokens):
        return None
    if tokens[purpose] in _POSTURE:
        return None
    return replace(np, constraints=(*np.constraints, *target.constraints[1:]))


#: Relation cues whose noun, in a need, is where to look rather than what is wanted
#: ("somewhere to sit near the counter"); after "on" or "in" the noun is where the need
#: is met ("I want to sit on the couch") and stays the target.
_NEED_ANCHOR_CUES = frozenset({"near", "left_of", "right_of", "in_front_of", "behind",
                               "between", "closest", "farthest", "above", "below", "end_of",
                               "corner_of"})  # fmt: skip


def _anchor_of_need(target: NounPhrase | None, items: list[Item]) -> NounPhrase | None:
    """A need's first noun phrase right after a spatial cue is the anchor of a relation of
    an unnamed target, not the target."""
    if target is None or target.mention is None:
        return target
    for k, it in enumerate(items):
        np = it.np
        if isinstance(np, NounPhrase) and np.mention is not None:
            if np.mention.start != target.mention.start:
                continue
            cue = items[k - 1].cue if k > 0 else None
            if cue is None or cue.kind not in _NEED_ANCHOR_CUES:
                return target
            anchor = replace(target, constraints=())
            span = (items[k - 1].start, it.end)
            relation = Constraint(cue.kind, (anchor,), span=span)
            return NounPhrase(None, constraints=(relation, *target.constraints))
    return target


def _place_of_need(target: NounPhrase | None) -> NounPhrase | None:
    """A need with no target phrase whose first relation is "on" or "in" something ("I
    want to lie down on the bed") asks for that something."""
    if target is None or target.mention is not None or not target.constraints:
        return target
    first = target.constraints[0]
    if first.kind not in ("supported_by", "inside") or len(first.anchors) != 1 or first.negated:
        return target
    place = first.anchors[0]
    return replace(place, constraints=(*place.constraints, *target.constraints[1:]))


def _set_question(tokens: tuple[str, ...], target: NounPhrase) -> bool:
    """A wh-question asks for a set unless it asks for one ("which chair is closest")."""
    if target.extremes or target.side or target.ordinal:
        return False
    if any(c.kind in ("closest", "farthest") for c in target.constraints):
        return False
    if tokens[0] == "which" and target.mention is not None and not target.mention.plural:
        return target.mention.generic
    return True


def _split_viewpoint(
    tokens: tuple[str, ...], describes: Callable[[str], bool] = lambda w: False
) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """Cut a viewpoint clause off the instruction: ``(viewpoint tokens, the rest)``.

    A viewpoint clause opens a clause ("facing the front of the couch, ...", "if you are
    standing at the door ...") or follows a subordinator inside one ("the second chair
    from the left when facing the windows"); only a subordinator or the observer ("you
    are", "your") may come before its trigger, so "the lamp standing by the bed" is no
    viewpoint, nor is "looking for" (searching). It ends at a comma or sentence end, or
    where the main clause starts without one ("facing the bed choose the lamp ...",
    "facing the stove it is the cabinet ...", "facing the sofa the table on the left"):
    see :func:`_view_clause_end`. A clause that would leave nothing else is no viewpoint
    ("look at the picture above the seat"). A comma between two words that ``describes``
    (adjectives: "looking towards the big, brown, round table, ...") lists them inside one
    noun phrase and ends nothing."""
    bounds = [-1, *(i for i, t in enumerate(tokens) if t in (",", ".", "?")
                    and not _listing(tokens, i, describes)), len(tokens)]  # fmt: skip
    for lo, hi in itertools.pairwise(bounds):
        start, end = lo + 1, hi
        trigger = _view_trigger(tokens, start, end)
        if trigger is None:
            continue
        first, at = trigger
        stop = _view_clause_end(tokens, at + 1, end)
        if stop == end and end < len(tokens):
            stop = end + 1  # drop the clause's separator with it
        main = (*tokens[:first], *tokens[stop:])
        while main and main[0] in (",", "."):
            main = main[1:]
        if not any(t not in (",", ".", "?") for t in main):
            continue
        return tokens[first:stop], main
    return (), tokens


def _listing(tokens: tuple[str, ...], i: int, describes: Callable[[str], bool]) -> bool:
    """Whether the comma at ``i`` follows an adjective inside a noun phrase: an adjective
    before it and, after it, another adjective or a word that opens no phrase or clause of
    its own ("the big, brown, round table"; not "the one that is white, the lamp ...")."""
    if tokens[i] != "," or not 0 < i < len(tokens) - 1 or not describes(tokens[i - 1]):
        return False
    after = tokens[i + 1]
    return describes(after) or (after.isalpha() and after not in _OPENS_PHRASE)


#: Words after a comma that start a phrase or clause of their own.
_OPENS_PHRASE = (
    g.DETERMINERS | g.PRONOUNS | g.VIEW_CLAUSE_OPENERS | g.VIEW_SUBORDINATORS | g.VIEW_TRIGGERS
    | g.WH_WORDS | {"and", "or", "but", "then", "you", "i", "we", "on", "in", "at", "to", "near",
                    "next", "by", "with", "please", "its", "is", "which", "that"}
)  # fmt: skip


def _view_trigger(tokens: tuple[str, ...], start: int, end: int) -> tuple[int, int] | None:
    """(where the viewpoint clause begins, where its trigger is) in ``tokens[start:end]``."""
    if start == 0 < end < len(tokens) and tokens[0] == "from" and tokens[1] in g.DETERMINERS:
        return 0, 0  # "from the doorway, the nightstand on the right": standing there
    for i in range(start, end):
        t = tokens[i]
        if t not in g.VIEW_TRIGGERS:
            continue
        if t == "back":
            if i == start or tokens[i - 1] not in g.OBSERVER_POSSESSIVES:
                continue  # "its back to the wall": how a thing faces, not where one stands
            if i - start < 4 and all(
                w in g.VIEW_OBSERVER or w == "with" for w in tokens[start : i - 1]
            ):
                return start, i  # "with your back to the window"
        if i + 1 < end and tokens[i + 1] == "for":
            return None  # "the one you are looking for"
        before = tokens[start:i]
        sub = max((j for j in range(start, i) if tokens[j] in g.VIEW_SUBORDINATORS), default=None)
        if sub is not None and all(w in g.VIEW_OBSERVER for w in tokens[sub + 1 : i]):
            return sub, i
        if i - start < 4 and all(w in g.VIEW_OBSERVER for w in before):
            return start, i
        return None
    return None


#: Words that may continue a viewpoint clause right before a determiner ("facing *the*
#: bed", "from *the* door", "looking at *all the* chairs").
_VIEW_CONTINUE = frozenset({"at", "to", "toward", "towards", "from", "of", "with", "on", "in",
                            "into", "by", "near", "across", "over", "through", "along",
                            "onto", "behind", "and", "all", "both", "directly", "straight",
                            "front", "up", "down", "out", "above", "below", "under", "beneath",
                            "beside", "next", "between", "against", "around", "past",
                            "opposite", "inside", "outside", "right", "just"})  # fmt: skip


#: Verbs of going that open the main clause after a viewpoint's "and" ("face the couch and
#: walk to the seat on the right").
_GOING = frozenset({"walk", "go", "move", "head", "step", "turn", "you"})
#: What follows "it" (or "its" for "it's") where it opens a clause: "it is the lamp".
_IT_IS = frozenset({"is", "was", "will", "would", "should", "the", "a", "an", "on", "in"})


def _view_clause_end(tokens: tuple[str, ...], i: int, end: int) -> int:
    """Where a viewpoint clause whose trigger ends before ``i`` gives way to the main
    clause (``end`` when it runs to the separator): at a word that opens a clause
    ("it", "this", "choose", "you", ...) or at a determiner right after a noun ("facing
    the sofa | the table ...")."""
    for j in range(i, end):
        t, prev = tokens[j], tokens[j - 1]
        following = tokens[j + 1] if j + 1 < end else ""
        if t in g.VIEW_CLAUSE_OPENERS or (t in ("it", "its") and following in _IT_IS):
            return j
        if t in ("and", "then") and (following in g.VIEW_CLAUSE_OPENERS or following in _GOING):
            return j + 1  # "face the couch and walk to the seat on the right"
        # "... to your right | the towel is ...": a side after a determiner is a noun
        side_noun = prev in ("left", "right") and tokens[j - 2] in g.DETERMINERS
        after_noun = side_noun or not (
            prev in _VIEW_CONTINUE or prev in g.DETERMINERS or prev in g.VIEW_TRIGGERS
        )
        if t in ("the", "a", "an") and after_noun and not prev.isdigit():
            return j
    return end


@dataclass(frozen=True, slots=True)
class _View:
    """What a viewpoint clause says: the entity in view, whether the observer stands at it,
    and where the observer stands while looking at another ("standing at the door looking
    at the windows": the door)."""

    entity: NounPhrase | None = None
    standing: bool = False
    observer: NounPhrase | None = None
    #: what the entity is shown "with" ("facing the wall with bags on it": the bags), the
    #: things an instruction that names nothing else picks among
    shown: NounPhrase | None = None


#: Words of coming into the room; said without a place, one comes in through its door.
_COMING_IN = frozenset({"enter", "enters", "entered", "entering", "in", "into"})


def _viewpoint(tokens: tuple[str, ...], index: CategoryIndex) -> _View:
    """The viewpoint entity of a viewpoint clause, and whether the observer stands at it
    (standing, sitting, entering at it and not looking or facing anywhere else; standing
    "at the foot of the bed" or "in front of the desk" faces it; "looking from" it); and
    the place of an observer who looks at something else from it."""
    if not tokens:
        return _View()
    nps = [it.np for it in read_items(tokens, index) if it.np is not None and it.np.resolved]
    named: list[NounPhrase] = [np for np in nps if not np.is_any]  # type: ignore[misc]
    if not named and any(t in _COMING_IN for t in tokens):
        # "as you walk in", "when you enter the room": one comes in through the door
        door = mention_at(index, ("door",), 0)
        if door is not None and door.categories:
            return _View(NounPhrase(door), standing=True)
    if not named:
        return _View()
    every = list(named)
    # the thing looked at is the phrase right after the last looking word ("facing the
    # picture on the wall": the picture), else the last one named ("standing at the door")
    looking = max((i for i, t in enumerate(tokens) if t in g.LOOKING), default=None)
    observer = None
    if looking is not None:
        after = [np for np in named if np.mention is not None and np.mention.start > looking]
        observer = _observer(tokens, named, looking, after[:1])
        named = after[:1] or named
    standing = (
        (any(t in g.STANDING_AT for t in tokens) or tokens[0] == "from")
        and not any(t in g.LOOKING for t in tokens)
        and not any(t in g.FACING_PLACES for t in tokens)
    )
    # "looking from the toilet", "seen from the door": the observer is at it; "viewing
    # from the foot of the bed" faces the bed, as standing at its foot does
    seen_from = any(
        t in g.LOOKING and nxt == "from" for t, nxt in itertools.pairwise(tokens)
    ) and not any(t in _LOOKED_AT or t in g.FACING_PLACES for t in tokens)
    shown = next(
        (np for np in every if np is not observer and _word_before(tokens, np) == "with"), None
    )
    if shown is None and observer is not None and _counted(tokens, observer):
        # "sitting in the two chairs facing the wall, the one on the left": one of the
        # chairs the observer is among, not of the wall
        shown = observer
    return _View(named[-1], standing or seen_from, observer, shown)


def _counted(tokens: tuple[str, ...], np: NounPhrase) -> bool:
    """Whether a number of more than one comes right before the phrase (past its
    determiners): "the two chairs", "both beds", "the 3 desks"."""
    if np.mention is None:
        return False
    j = np.mention.start - 1
    while j >= 0 and tokens[j] in ("the", "these", "those"):
        j -= 1
    if j < 0:
        return False
    return number_word(tokens[j]) > 1


#: Words before "the two chairs" that make the number a group the target is picked from
#: or an anchor ("the left *of* the two chairs", "*between* the two chairs", "there *are*
#: two chairs"), not how many the target is.
_GROUPING = frozenset({"of", "between", "among", "amongst", "are", "is", "with", "from"})


#: Words between a count and its noun that rank by distance ("the two closest stools").
_RANKING = frozenset({"closest", "nearest", "farthest", "furthest"})


def _count_of(tokens: tuple[str, ...], np: NounPhrase, lexicon: Lexicon) -> int | None:
    """How many the phrase asks for when a number of more than one comes before its
    plural noun, past size and colour words, no word before the number makes it a group
    and the sentence picks no "one" ("the two stools closest to the window", "the 3
    tallest chairs"; not "the left of the two chairs", "of the two stools, the one by the
    window"); else ``None``.

    >>> from causalsplat.reason.lexicon import load_lexicon
    >>> chairs = NounPhrase(Mention(3, 4, "chair", ("chair",), 1.0, plural=True))
    >>> _count_of(("the", "two", "tallest", "chairs"), chairs, load_lexicon())
    2
    >>> _count_of(("of", "the", "two", "chairs"), chairs, load_lexicon()) is None
    True
    """
    mention = np.mention
    if mention is None or mention.generic or not mention.plural:
        return None
    if lexicon.phrase_lemma(tokens[mention.start : mention.end]) != mention.phrase:
        return None  # a phrase of another clause (the viewpoint's)
    if "one" in tokens:
        return None  # "two towers are on this side, select the one nearest the window"
    j = mention.start - 1
    while j >= 0 and (tokens[j] in _RANKING or tokens[j] in g.EXTREMES or is_color_word(tokens[j])):
        j -= 1
    if j < 0:
        return None
    n = number_word(tokens[j])
    if n < 2:
        return None
    j -= 1
    while j >= 0 and tokens[j] in ("the", "these", "those"):
        j -= 1
    return None if j >= 0 and tokens[j] in _GROUPING else n


#: Words before "the two chairs" that make the target one of that many standing together
#: ("the left *of* the two chairs", "*out of* the three lamps").
_PARTITIVE = frozenset({"of", "among", "amongst", "from"})


def _of_a_group(tokens: tuple[str, ...], np: NounPhrase, lexicon: Lexicon) -> NounPhrase:
    """``np`` picked from a counted group it names, with no relation but closest or farthest
    ("the right-hand of the two side-by-side doors", "of the three chairs, the one closest
    to the door") keeps to where that many of its kind stand together (a ``side_with``
    constraint on its own kind, the first of its constraints); else ``np`` as it is."""
    mention = np.mention
    if mention is None or mention.generic or not mention.plural:
        return np
    if any(c.kind not in ("closest", "farthest") for c in np.constraints):
        return np  # "of the two tables under the window": the relation makes the group
    if lexicon.phrase_lemma(tokens[mention.start : mention.end]) != mention.phrase:
        return np  # a phrase of another clause (the viewpoint's)
    j = mention.start - 1
    while j >= 0 and (tokens[j] in g.EXTREMES or is_color_word(tokens[j]) or tokens[j] in
                      ("side", "by", "-")):  # fmt: skip
        j -= 1  # "the two side by side doors"
    n = number_word(tokens[j]) if j >= 0 else 0
    j -= 1
    while j >= 0 and tokens[j] in ("the", "these", "those"):
        j -= 1
    if n < 2 or j < 0 or tokens[j] not in _PARTITIVE:
        return np
    group = NounPhrase(mention, count=n)
    return replace(np, constraints=(Constraint("side_with", (group,)), *np.constraints))


def _word_before(tokens: tuple[str, ...], np: NounPhrase) -> str | None:
    """The word before the phrase, past its determiners and numbers ("with *the 2* bags"),
    or ``None`` at the start."""
    if np.mention is None:
        return None
    j = np.mention.start - 1
    while j >= 0 and (tokens[j] in g.DETERMINERS or tokens[j].isdigit()):
        j -= 1
    return tokens[j] if j >= 0 else None


def _observer(
    tokens: tuple[str, ...], named: list[NounPhrase], looking: int, faced: list[NounPhrase]
) -> NounPhrase | None:
    """Where an observer who looks at ``faced`` stands: the first other phrase after a word
    of standing ("standing at the door looking at the windows") or after a "from" that is
    not the looking word's own ("looking at the window from the door")."""
    if not faced:
        return None
    places = [
        i for i, t in enumerate(tokens) if t in g.STANDING_AT or (t == "from" and i != looking + 1)
    ]
    for np in named:
        m = np.mention
        if np is faced[0] or m is None or set(np.categories) == set(faced[0].categories):
            continue
        if any(
            i < m.start and all(t not in g.LOOKING for t in tokens[i : m.start]) for i in places
        ):
            return np
    return None


#: Words naming where an observer looks ("looking from the door *at* the bed").
_LOOKED_AT = frozenset({"at", "toward", "towards", "into", "facing", "face"})


#: Verbs that say which object is meant ("choose the", "you want the").
_PICKING = frozenset({"choose", "chose", "select", "pick", "click", "find", "grab", "identify",
                      "want", "need", "seek"})  # fmt: skip
#: What may open a clause before a picking verb ("then you want", "please select").
_PICK_OPENERS = frozenset({"you", "are", "then", "now", "please", "and", "so", "i", "we",
                           "would", "should", "will", "to", "it", "is", "just"})  # fmt: skip
_SEARCHING = frozenset({"looking", "look", "searching", "search"})


def _picked_clause(tokens: tuple[str, ...], items: list[Item]) -> int | None:
    """Where a later clause opens that picks the target ("..., choose the pillow", ". you
    want the chair", ", you are looking for the desk"): a picking verb after a separator,
    with only clause openers between, right before a phrase naming a category; ``None``
    when the first phrase of the instruction is already the one picked."""
    nps = [it for it in items if it.np is not None]
    if not nps:
        return None
    first_np = nps[0].start
    for it in items:
        if not it.separator or it.start < first_np:
            continue
        j = it.end
        while j < len(tokens) and tokens[j] in _PICK_OPENERS:
            j += 1
        if j >= len(tokens):
            return None
        verb = tokens[j]
        if _names_another(tokens, it.end, nps):
            return it.end  # "there is a bookshelf between two doors. it is the door on ..."
        if verb in _SEARCHING and j + 1 < len(tokens) and tokens[j + 1] == "for":
            j += 1
        elif verb not in _PICKING or (verb in ("want", "need") and tokens[j - 1] != "you"):
            continue
        after = next((n for n in nps if n.start > j), None)
        if after is None or after.np.is_any:  # type: ignore[attr-defined]
            continue
        if any(t in (",", ".", "?") for t in tokens[j : after.start]):
            continue
        return it.end
    return None


def _names_another(tokens: tuple[str, ...], start: int, nps: list[Item]) -> bool:
    """Whether the clause at ``start`` says "it is the N" (or "its the N") where N names a
    kind that the instruction's first phrase does not: the thing meant, the first phrase
    only leading to it."""
    j = start
    if tokens[j : j + 2] == ("it", "is"):
        j += 2
    elif tokens[j : j + 1] == ("its",):
        j += 1
    else:
        return False
    if tokens[j : j + 1] != ("the",):
        return False
    named = next((n.np for n in nps if n.start == j + 1), None)
    first = nps[0].np
    if named is None or named.is_any or first.is_any:  # type: ignore[attr-defined]
        return False
    return not set(named.categories) & set(first.categories)  # type: ignore[attr-defined]


def _removed(target: NounPhrase | None) -> tuple[NounPhrase, ...]:
    if target is None:
        return ()
    return tuple(np for np in (target, *target.coordinated) if not np.is_any)


def _action_words(tokens: tuple[str, ...], items: list[Item]) -> tuple[str, ...]:
    """Words describing an action or need: every word outside named noun phrases and the
    relation cues that lead to them, less stop words; bodily states become their action."""
    skip: set[int] = set()
    for k, it in enumerate(items):
        named = it.np is not None and bool(it.np.categories)  # type: ignore[attr-defined]
        if named or it.mod is not None:
            skip.update(range(it.start, it.end))
        if named and k > 0 and items[k - 1].cue is not None:
            skip.update(range(items[k - 1].start, items[k - 1].end))
    words: list[str] = []
    for i, t in enumerate(tokens):
        if i in skip or t in (",", ".", "?") or t in g.ACTION_STOPWORDS:
            continue
        words.extend((g.state_at(tokens, i) or t).split())
    if tokens and tokens[-1] in g.PARTICLES and (len(tokens) - 1) not in skip:
        words.append(tokens[-1])
    return tuple(words)


class _Reader:
    """Assigns roles to the items: target, anchors, coordinated phrases, constraints.

    The first noun phrase is the target. After a wh-word ("what is the cup on?", "which
    chair is ...") the next phrase is its *subject*: it becomes the target unless a cue is
    left without an anchor, in which case the question asks for the entities in the
    inverse relation to it. A "with NP <cue> it" clause is the inverse of the cue ("the
    table with a lamp on it": the table supports the lamp) and belongs to the phrase right
    before "with". A cue followed by "it" points at the viewpoint entity, or at the last
    phrase that was not yet given a role ("there is a chair in front of it").
    """

    def __init__(
        self, items: list[Item], viewpoint: NounPhrase | None, tokens: tuple[str, ...] = ()
    ) -> None:
        self.items = items
        self.viewpoint = viewpoint
        self.tokens = tokens
        self.target: NounPhrase | None = None
        self.subject: NounPhrase | None = None
        self.closed = False  # a clause ended after the target: no subject any more
        self.free: NounPhrase | None = None
        self.constraints: list[Constraint] = []
        self.mods: list[Modifier] = []
        self.last_anchor_end = -1  # item index after the last constraint's anchors
        self.with_kind: str | None = None  # the relation of the last "with" / "has" cue

    def read(self) -> NounPhrase | None:
        items = self.items
        negated = False
        shared: list[tuple[str, int]] = []  # relations waiting for the next one's anchor
        k = 0
        while k < len(items):
            it = items[k]
            if it.negation:
                negated = True
            elif it.mod is not None and (np := self._neighbour_side(k)) is not None:
                # "... there is a chair to the left": the target is right of that chair
                kind = "right_of" if it.mod.value == "left" else "left_of"
                m = np.mention
                span = (m.start if m is not None else it.start, it.end)
                self.constraints.append(Constraint(kind, (np,), span=span))
            elif it.mod is not None:
                mod = it.mod
                if negated and mod.kind in ("place", "attribute", "side", "extreme"):
                    # "not the one in the corner", "the chair that is not black", "not the
                    # door to your left"
                    mod = replace(mod, negated=True)
                    negated = False
                self.mods.append(mod)
            elif it.np is not None:
                if self._noun_phrase(k, it.np, negated=negated):  # type: ignore[arg-type]
                    negated = False
            elif it.cue is not None and self._before_its_noun(k):
                k = self._superlative(k)
                negated = False
                continue
            elif it.cue is not None and self._shares_anchor(k):
                # "to the left of and in front of the armchair": both of the armchair
                shared.append((it.cue.kind, it.start))
                k += 2
                continue
            elif it.cue is not None:
                nested = k == self.last_anchor_end and it.cue.kind == "with"
                first = k
                k, constraint = self._constraint(k)
                if constraint is not None and constraint.anchors and shared:
                    for kind, start in shared:
                        span = (start, items[k - 1].end)
                        self._add(Constraint(kind, constraint.anchors, negated=negated,
                                             span=span), nested=False)  # fmt: skip
                shared.clear()
                denied = negated or (constraint is not None and constraint.negated)
                also = self._second_anchor(k, constraint, denied)
                if constraint is not None and not constraint.anchors:
                    # a cue left without its anchor asks about the subject only where
                    # the clause ends on it ("what is the cup on?"), never before a place
                    # it names ("it is the only table in the room")
                    end = items[k - 1].end
                    if end < len(self.tokens) and self.tokens[end] not in (",", ".", "?"):
                        constraint = None
                if constraint is not None:
                    span = (items[first].start, items[k - 1].end)
                    negated = negated or constraint.negated
                    if also is not None:
                        # "to the right of the curtains and the bike": of both; the
                        # first named stays the last relation, whose anchor breaks ties
                        also_span = (items[k + 1].start, items[k + 1].end)
                        self._add(Constraint(constraint.kind, (self._anchor_kind(also),),
                                             negated=negated, span=also_span),
                                  nested=False)  # fmt: skip
                    self._add(replace(constraint, negated=negated, span=span), nested=nested)
                    self.last_anchor_end = k
                    if it.cue.kind == "with" and not nested:
                        self.with_kind = constraint.kind
                    if also is not None:
                        k += 2
                negated = False
                continue
            elif it.separator:
                self.free = None
                self.closed = self.target is not None
                negated = False  # "the couch with no back, by the plant": by it
            k += 1
        return self._finish()

    def _noun_phrase(self, k: int, np: NounPhrase, *, negated: bool = False) -> bool:
        """Give the phrase its role; ``True`` when it took a negation before it ("the
        brown door, not the white one": the target is not white)."""
        if (
            negated
            and self.target is not None
            and (np.attributes or np.extremes)
            and not self.target.is_any
            and (np.is_any or set(np.categories) == set(self.target.categories))
        ):
            # "not the white one", "that isn't the biggest one"
            self.target = replace(
                self.target,
                not_attributes=(*self.target.not_attributes, *np.attributes),
                not_extremes=(*self.target.not_extremes, *np.extremes),
            )
            return True
        if (
            negated
            and self.constraints
            and self.constraints[-1].anchors
            and self.constraints[-1].kind != "with"
            and self.target is not None
            and not self.target.is_any
            and np.categories
            and not np.is_any
            and not np.constraints
            and not set(np.categories) & set(self.target.categories)
            and k > 0
            and self.items[k - 1].negation
            and self.tokens[self.items[k - 1].start] == "not"
        ):
            # "this plant is on the windowsill, not the table": the relation just said is
            # denied of the other thing (never of the target's own kind: "not the one
            # over the fireplace" says which target)
            last = self.constraints[-1]
            m = np.mention
            span = (m.start, m.end) if m is not None else (0, 0)
            self.constraints.append(Constraint(last.kind, (np,), negated=True, span=span))
            return True
        if negated and self.with_kind is not None and np.categories and not np.is_any:
            # "the table that has a book on it, but no lamp and no plant": what it has
            # not, in the same relation
            m = np.mention
            span = (m.start, m.end) if m is not None else (0, 0)
            self.constraints.append(Constraint(self.with_kind, (np,), negated=True, span=span))
            return True
        if self.target is None or (
            not self.target.resolved
            and np.resolved
            and not np.is_any
            and not self.constraints
            # "a light source for the floor": what the thing is for, never the thing
            and _word_before(self.tokens, np) != "for"
        ):
            self.target = np
        elif (
            self.target.is_any
            and self.target.mention is not None
            and self.subject is None
            and not self.closed
        ):
            self.subject = np
        elif (
            np.is_any
            and np.mention is not None
            and not self.target.is_any
            and (_modified(np) or not (k > 0 and self.items[k - 1].conjunction))
        ):
            # "the coffee table is the furthest left one", "there are six benches, and you
            # want the leftmost one": "one" is the target again, and what singles it out
            # singles out the target
            self.target = _merge_modifiers(self.target, np)
        elif (
            _modified(np)
            and not np.is_any
            and not self.target.is_any
            and np.categories
            and set(np.categories) == set(self.target.categories)
            and not (k > 0 and self.items[k - 1].conjunction)
        ):
            # "this is a blue chair. it is the third chair from the right": the target
            # named again, with what singles it out
            self.target = _merge_modifiers(self.target, _without_repeats(np, self.target))
        elif (
            _modified(np)
            and self.target.is_any
            and self.subject is not None
            and np.categories
            and set(np.categories) == set(self.subject.categories)
            and not (k > 0 and self.items[k - 1].conjunction)
        ):
            # "one of many swivel chairs sits before a desk. it is the third chair from the
            # left": the chairs the "one" is of, named again
            self.subject = _merge_modifiers(self.subject, _without_repeats(np, self.subject))
        elif k > 0 and self.items[k - 1].conjunction and not self.constraints:
            self.target = replace(self.target, coordinated=(*self.target.coordinated, np))
        else:
            self.free = np
        return False

    def _second_anchor(
        self, k: int, constraint: Constraint | None, denied: bool = False
    ) -> NounPhrase | None:
        """The phrase joined by "and" to the anchor of the relation just read (items up
        to ``k``), when the clause ends after it: "next to a toilet and a trash can." (not
        "next to the table and the lamp is on it", nor the two of "between"); also by "or"
        when the relation is ``denied`` ("not by the toilet or the desk": by neither)."""
        items, tokens = self.items, self.tokens
        if (
            constraint is None
            or not constraint.anchors
            or constraint.kind in ("between", "with")
            or k + 1 >= len(items)
            or not items[k].conjunction
            or tokens[items[k].start] not in (("and", "or") if denied else ("and",))
        ):
            return None
        np = items[k + 1].np
        if np is None or np.is_any or not np.resolved:  # type: ignore[attr-defined]
            return None
        end = items[k + 1].end
        if end < len(tokens) and tokens[end] not in (",", ".", "?"):
            return None
        return np  # type: ignore[return-value]

    def _shares_anchor(self, k: int) -> bool:
        """Whether the relation cue at ``k`` has no anchor of its own but is joined by
        "and" to the next cue, whose anchor it shares: "to the left of and in front of the
        armchair" (not "or", which asks either; nor "with" / "has": what a thing has is no
        place)."""
        items = self.items
        return (
            k + 2 < len(items)
            and items[k + 1].conjunction
            and items[k + 2].cue is not None
            and "with" not in (items[k].cue.kind, items[k + 2].cue.kind)  # type: ignore[union-attr]
            and self.tokens[items[k + 1].start] == "and"
        )

    def _before_its_noun(self, k: int) -> bool:
        """ "the closest chair (to the door)": a closest / farthest cue without its "to" /
        "from", right before the first noun phrase, qualifies that phrase."""
        items, cue = self.items, self.items[k].cue
        assert cue is not None
        after = items[k + 1].np if k + 1 < len(items) else None
        # "the chair is the closest one to the door": "one" is the chair named again
        again = getattr(getattr(after, "mention", None), "phrase", None) in ("one", "ones")
        # "what is the closest stool to the window?": the wh-word asks for that stool
        asked = (
            self.target is not None and self.target.is_any and self.subject is None
            and not self.constraints and not _modified(self.target)
        )  # fmt: skip
        return (
            cue.kind in ("closest", "farthest")
            and (self.target is None or again or asked)
            and bool(self.tokens)
            and self.tokens[cue.end - 1] not in ("to", "from", "as", "where", "what")
            and k + 1 < len(items)
            and items[k + 1].np is not None
            and items[k + 1].start == cue.end
        )

    def _superlative(self, k: int) -> int:
        """The phrase after the cue is the target; it is measured from the phrase after a
        "to" / "from" ("the closest chair to the door"), else from the viewpoint entity
        ("standing at the table, it is the closest chair"); with neither, the cue is
        dropped. Returns the next item index."""
        items, cue = self.items, self.items[k].cue
        assert cue is not None
        np = items[k + 1].np
        self._noun_phrase(k + 1, np)  # type: ignore[arg-type]
        k += 2
        anchor: NounPhrase | None = None
        if (
            k < len(items)
            and items[k].np is not None
            and any(t in ("to", "from") for t in self.tokens[items[k - 1].end : items[k].start])
        ):
            anchor = items[k].np  # type: ignore[assignment]
            k += 1
        elif self.viewpoint is not None:
            anchor = self.viewpoint
        if anchor is not None:
            span = (cue.start, items[k - 1].end)
            self.constraints.append(Constraint(cue.kind, (anchor,), span=span))
        return k

    def _add(self, constraint: Constraint, *, nested: bool) -> None:
        if nested and self.constraints and self.constraints[-1].anchors:
            last = self.constraints[-1]
            anchor = last.anchors[-1]
            anchor = replace(anchor, constraints=(*anchor.constraints, constraint))
            self.constraints[-1] = replace(last, anchors=(*last.anchors[:-1], anchor))
        else:
            self.constraints.append(constraint)

    def _finish(self) -> NounPhrase | None:
        target = self.target
        if target is None:
            kept = tuple(c for c in self.constraints if c.anchors)
            # "somewhere to sit near the counter": no target phrase, but a relation; "the
            # second from the left": no target phrase, but what singles it out
            if not kept and not self.mods:
                return None
            return _with_modifiers(NounPhrase(None, constraints=kept), self.mods)
        constraints = self.constraints
        if self.subject is not None:
            if any(not c.anchors for c in constraints):
                constraints = [
                    c if c.anchors else replace(c, anchors=(self.subject,), kind=_inverse(c.kind))
                    for c in constraints
                ]
            else:
                target = _merge_modifiers(self.subject, target)
        target = _with_modifiers(target, self.mods)
        kept = tuple(c for c in constraints if c.anchors)
        return _level_to_target(replace(target, constraints=(*target.constraints, *kept)))

    def _constraint(self, k: int) -> tuple[int, Constraint | None]:
        """Read the cue at ``k`` and its anchors; returns the next index and the constraint
        (with no anchors when the cue dangles, or ``None`` when it means nothing)."""
        items = self.items
        cue = items[k].cue
        assert cue is not None
        k += 1
        # "the table that has no lamp", "a desk with no chair at it": the relation denied
        denied = (
            cue.kind == "with"
            and k + 1 < len(items)
            and items[k].negation
            and items[k + 1].np is not None
        )
        if denied:
            k += 1
        anchors: list[NounPhrase] = []
        while k < len(items) and items[k].np is not None:
            anchors.append(items[k].np)  # type: ignore[arg-type]
            k += 1
            if cue.kind != "between" or len(anchors) >= 2:
                break
            if k < len(items) and items[k].conjunction:
                k += 1
        if cue.kind == "with":
            k, constraint = self._with(k, anchors)
            if denied and constraint is not None:
                constraint = replace(constraint, negated=True)
            return k, constraint
        if anchors and self._is_target_again(anchors[0]):
            beside = self._neighbour(k)
            if beside is not None:
                # "the desk is against the wall. in front of the desk is a chair": a chair
                # in front of the desk, which is behind it
                return k + 1, Constraint(_inverse(cue.kind), (beside,))
            free = self.free
            if (
                free is not None
                and cue.kind in _TURNABLE
                and free.categories
                and not free.is_any
                and set(free.categories) != set(anchors[0].categories)
            ):
                # "this is a black chair. a whiteboard is behind the chair": the clause
                # describes the whiteboard, and the chair is in front of it
                self.free = None
                return k, Constraint(_inverse(cue.kind), (free,))
        if not anchors and k < len(items) and items[k].back_reference:
            while k < len(items) and items[k].back_reference:
                k += 1
            beside = self._neighbour(k)
            if beside is not None and self.target is not None and cue.kind != "between":
                return k + 1, Constraint(_inverse(cue.kind), (beside,))  # "in front of it is"
            if self.viewpoint is not None:
                anchors = [self.viewpoint]
            elif self.free is not None:
                return k, Constraint(_inverse(cue.kind), (self.free,))
        if cue.kind == "between":
            if not anchors:
                return k, None
            if len(anchors) < 2:
                # "between the two chairs": one plural anchor names both ends; a singular
                # one ("between the bed") can only mean next to it.
                mention = anchors[0].mention
                if mention is not None and mention.plural:
                    return k, Constraint("between", (anchors[0],))
                return k, Constraint("closest", (anchors[0],))
        words = self.tokens[cue.start : cue.end]
        if cue.kind == "side_with":
            # "in the cluster of three by the counter": three of the target's kind
            group = anchors[0] if anchors else self.target
            if group is None:
                return k, None
            # the cue ends with the count of the things that stand together there, or
            # names a pair
            count = number_word(words[-1]) or 2
            return k, Constraint(cue.kind, (replace(group, count=count, constraints=()),))
        far = "far" in words or self.tokens[max(0, cue.start - 3) : cue.start] == _ALL_THE_WAY
        anchors = [self._anchor_kind(a) for a in anchors]
        return k, Constraint(cue.kind, tuple(anchors), far=far)

    def _anchor_kind(self, np: NounPhrase) -> NounPhrase:
        """The kinds an anchor names, read against the target's: an anchor not named
        outright (below :data:`NAMED`: by meaning, a WordNet relative) that also takes in
        the target's own kind is the other kinds ("the chair closest to the recliner", a
        recliner being a kind of chair: the massage chair); an anchor "one" is another of
        the target's kind ("a large shelf next to the tall skinny one": the tallest
        shelf)."""
        m, target = np.mention, self.target
        if (
            m is not None
            and not m.generic
            and m.score < NAMED
            and target is not None
            and set(target.categories) & set(m.categories)
            and set(m.categories) - set(target.categories)
        ):
            rest = tuple(c for c in m.categories if c not in target.categories)
            return replace(np, mention=replace(m, categories=rest))
        if (
            m is None
            or not m.generic
            or m.phrase not in ("one", "ones")
            or target is None
            or target.is_any
            or not target.categories
            or target.mention is None
        ):
            return np
        kind = replace(m, categories=target.categories, score=target.mention.score, generic=False)
        return replace(np, mention=kind)

    def _neighbour_side(self, k: int) -> NounPhrase | None:
        """The phrase a side modifier at item ``k`` places beside the target ("... there is
        a chair to the left"): right before it, said after the target by "there is / are"
        with only determiners or a count between; else ``None``."""
        items, mod = self.items, self.items[k].mod
        if mod is None or mod.kind != "side" or mod.value not in ("left", "right") or k == 0:
            return None
        before = items[k - 1]
        np = before.np
        if np is None or self.target is None or np is self.target or np.is_any:  # type: ignore[attr-defined]
            return None
        j = before.start - 1
        while j >= 0 and (self.tokens[j] in g.DETERMINERS or self.tokens[j].isdigit()
                          or self.tokens[j] in _COUNTS):  # fmt: skip
            j -= 1
        if j < 1 or self.tokens[j] not in ("is", "are", "s") or self.tokens[j - 1] != "there":
            return None
        return np  # type: ignore[return-value]

    def _is_target_again(self, np: NounPhrase) -> bool:
        """Whether ``np`` names the target again, as it was said ("the desk" after "the
        wooden desk"): its kind, nothing that singles one out."""
        target = self.target
        return (
            target is not None
            and not target.is_any
            and not np.is_any
            and bool(np.categories)
            and set(np.categories) == set(target.categories)
            and not _modified(np)
            and not np.constraints
        )

    def _neighbour(self, k: int) -> NounPhrase | None:
        """The phrase at item ``k`` when only a copula leads to it ("... is a chair",
        "... there are two chairs", "... sits a lamp"): a thing described beside the target,
        not the target."""
        items = self.items
        if k >= len(items) or items[k].np is None or k == 0:
            return None
        words = self.tokens[items[k - 1].end : items[k].start]
        if not words or words[0] not in _COPULAS or any(w in _CLAUSE_WORDS for w in words):
            return None
        np = items[k].np
        return None if np.is_any else np  # type: ignore[union-attr,return-value]

    def _with(self, k: int, anchors: list[NounPhrase]) -> tuple[int, Constraint | None]:
        items = self.items
        if not anchors:
            return k, None
        tail = items[k].cue if k < len(items) else None
        if tail is not None and k + 1 < len(items) and items[k + 1].np is not None:
            # "the side with chairs against the wall": where the chairs are, not a second
            # relation of the side
            where = Constraint(tail.kind, (items[k + 1].np,))  # type: ignore[arg-type]
            anchor = replace(anchors[0], constraints=(*anchors[0].constraints, where))
            return k + 2, Constraint("with", (anchor,))
        if tail is not None and tail.kind in g.WITH_TAIL:
            k += 1
            while k < len(items) and items[k].back_reference:
                k += 1
            return k, Constraint(g.WITH_TAIL[tail.kind], (anchors[0],))
        return k, Constraint("with", (anchors[0],))


def _level_to_target(target: NounPhrase) -> NounPhrase:
    """ "the books on the highest shelf", "the box on the bottom shelf": the height word
    picks among the things on the shelves (the highest books), not among the bookcases,
    and they are at the bookcase (on one of its levels), not on top of it."""
    if target.extremes or target.is_any:
        return target
    constraints = list(target.constraints)
    for k, c in enumerate(constraints):
        if c.kind not in ("supported_by", "inside") or c.negated or len(c.anchors) != 1:
            continue
        anchor = c.anchors[0]
        head = anchor.mention.phrase.split()[-1] if anchor.mention is not None else ""
        vertical = [e for e in anchor.extremes if e[0] is Metric.Z]
        if head not in g.LEVELS or not vertical:
            continue
        rest = tuple(e for e in anchor.extremes if e[0] is not Metric.Z)
        # on one of its levels is at the piece of furniture (measured boxes of what is on
        # its shelves stick out of its own), not on top of it
        constraints[k] = replace(c, kind="near", anchors=(replace(anchor, extremes=rest),))
        return replace(target, extremes=(vertical[0],), constraints=tuple(constraints))
    return target


def _with_modifiers(np: NounPhrase, mods: list[Modifier]) -> NounPhrase:
    if not mods:
        return np
    attributes = [m for m in mods if m.kind == "attribute"]
    return replace(
        np,
        attributes=(*np.attributes, *(m.value for m in attributes if not m.negated)),
        not_attributes=(*np.not_attributes, *(m.value for m in attributes if m.negated)),
        extremes=(
            *np.extremes,
            *((m.metric, m.direction) for m in mods if m.kind == "extreme" and not m.negated),
        ),
        not_extremes=(
            *np.not_extremes,
            *((m.metric, m.direction) for m in mods if m.kind == "extreme" and m.negated),
        ),
        side=np.side or next((m.value for m in mods if m.kind == "side"), None),
        side_negated=(
            np.side_negated if np.side else any(m.negated for m in mods if m.kind == "side")
        ),
        place=np.place or next((m.value for m in mods if m.kind == "place"), None),
        place_negated=(
            np.place_negated if np.place else any(m.negated for m in mods if m.kind == "place")
        ),
        ordinal=np.ordinal or next((m.number for m in mods if m.kind == "ordinal"), None),
    )


def _modified(np: NounPhrase) -> bool:
    """Whether anything besides its noun singles the phrase out."""
    return bool(
        np.attributes or np.extremes or np.not_extremes or np.side or np.place or np.ordinal
    )


def _merge_modifiers(subject: NounPhrase, target: NounPhrase) -> NounPhrase:
    """ "where is the cup" -> the cup (with the wh-phrase's modifiers); "the table is the
    leftmost one" -> the table (with the one's)."""
    return replace(
        subject,
        attributes=(*subject.attributes, *target.attributes),
        not_attributes=(*subject.not_attributes, *target.not_attributes),
        extremes=(*subject.extremes, *target.extremes),
        not_extremes=(*subject.not_extremes, *target.not_extremes),
        side=subject.side or target.side,
        side_negated=subject.side_negated if subject.side else target.side_negated,
        place=subject.place or target.place,
        place_negated=subject.place_negated if subject.place else target.place_negated,
        ordinal=subject.ordinal or target.ordinal,
    )


def _without_repeats(np: NounPhrase, target: NounPhrase) -> NounPhrase:
    """``np`` less the attributes and extremes ``target`` already has ("a black chair. the
    black chair is the third one": black once)."""
    return replace(
        np,
        attributes=tuple(a for a in np.attributes if a not in target.attributes),
        extremes=tuple(e for e in np.extremes if e not in target.extremes),
    )


_INVERSE = {
    "supported_by": "supports", "supports": "supported_by", "above": "below",
    "below": "above", "inside": "contains", "contains": "inside", "left_of": "right_of",
    "right_of": "left_of", "in_front_of": "behind", "behind": "in_front_of",
}  # fmt: skip
#: Relations that read the other way round ("A above B" is "B below A").
_TURNABLE = frozenset({*_INVERSE, "near"})


def _demonstrated(
    target: NounPhrase, tokens: tuple[str, ...], viewpoint: NounPhrase | None
) -> NounPhrase:
    """The phrase a demonstrative points at is the one described: "there are plants next to
    this cabinet" describes the cabinet (near the plants), "there is no dispenser above
    this trash can" the trash can (not below a dispenser). Only a target with that one
    relation, whose one anchor follows "this", is turned round (stage 1's items leave
    "this" before a noun said before as a pointer back, never such an anchor)."""
    if len(target.constraints) != 1 or target.mention is None or target.is_any:
        return target
    (c,) = target.constraints
    if len(c.anchors) != 1 or c.kind not in _TURNABLE:
        return target
    (anchor,) = c.anchors
    m = anchor.mention
    # the viewpoint's phrase ("standing at the desk, the closest chair") was read from the
    # viewpoint clause's tokens, not these
    if m is None or anchor is viewpoint or anchor.is_any or not anchor.categories:
        return target
    if not 0 < m.start < m.end <= len(tokens):
        return target
    if tokens[m.start - 1] != "this":
        return target
    described = replace(target, constraints=())
    turned = Constraint(_inverse(c.kind), (described,), negated=c.negated, span=c.span)
    return replace(anchor, constraints=(*anchor.constraints, turned))


_ALL_THE_WAY = ("all", "the", "way")
#: Words that count a phrase ("there are *two* chairs", "*several* boxes").
_COUNTS = frozenset(NUMBER_WORDS) | {"several", "many"}
#: Verbs that set a described thing beside the target ("next to it *is* a lamp").
_COPULAS = frozenset({"is", "are", "there", "sits", "sit", "stands", "stand", "lies", "hangs"})
#: Words that end a clause or open another one.
_CLAUSE_WORDS = frozenset({",", ".", "?", "and", "but", "which", "that", "where", "when", "it",
                           "not", "no"})  # fmt: skip


def _inverse(kind: str) -> str:
    return _INVERSE.get(kind, kind)
