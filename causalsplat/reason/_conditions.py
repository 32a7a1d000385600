"""Counterfactual conditions in any word order: the clause that removes something.

A counterfactual is a question about the scene after something is taken away or gives
way. The condition may come first ("if the bed is removed, what falls?") or last ("what
falls if the bed is removed?"), open with any conditional subordinator ("if", "when",
"once", "suppose", "imagine", "in case"...) and use any verb of removal ("remove", "take
away", "drag out", "haul away", "rip out", "get rid of") or of collapse ("give way",
"collapse", "break", "cave in"). Verbs are matched by lemma, so tense and number do not
matter ("someone drags the table out", "the tub was ripped out", "the shelf gave way").

The verbs are general lexical knowledge (the removal and collapse senses of common
English verbs, with the particles they need), not phrasings from any evaluation file.

>>> split_condition(tuple("what falls if someone drags the table out ?".split()))
(('the', 'table'), ('what', 'falls', '?'))
>>> split_condition(tuple("if the shelf gave way , what drops ?".split()))
(('the', 'shelf'), ('what', 'drops', '?'))
>>> split_condition(tuple("suppose the lamp on the desk were taken away".split()))
(('the', 'lamp', 'on', 'the', 'desk'), ())
>>> split_condition(tuple("what is on the table if i look from the door".split())) is None
True
>>> split_condition(tuple("if the table is removed what falls".split()))
(('the', 'table'), ('what', 'falls'))
>>> split_condition(tuple("what loses its support when the table goes ?".split()))
(('the', 'table'), ('what', 'loses', 'its', 'support', '?'))
>>> split_condition(tuple("what is left hanging without the table ?".split()))
(('the', 'table'), ('what', 'is', 'left', 'hanging', '?'))
>>> split_condition(tuple("the chair without arms".split())) is None
True
>>> split_condition(tuple("what would hit the floor were the shelf to snap ?".split()))
(('the', 'shelf'), ('what', 'would', 'hit', 'the', 'floor', '?'))
>>> split_condition(tuple("what goes down with the desk if it collapses ?".split()))
(('the', 'desk'), ('what', 'goes', 'down', 'with', 'the', 'desk', '?'))

"Without X" is a condition only in a question of what falls ("what drops without the
shelf?"): elsewhere it describes ("the lamp without a shade", "which chair is without a
cushion?").
"""

from __future__ import annotations

from collections.abc import Iterator

from causalsplat.reason._grammar import DEFINITE, DETERMINERS, PRONOUNS
from causalsplat.reason._text import NUMBER_WORDS

#: Words that open a condition clause (the first token of a two-word one is the key).
SUBORDINATORS = frozenset({"if", "when", "once", "after", "suppose", "supposing", "imagine",
                           "assuming", "assume", "should", "whenever", "say"})  # fmt: skip
#: Two-word openers: "in case", "what if" (the "what" is not the question's subject).
_OPENERS_2 = frozenset({("in", "case"), ("what", "if"), ("provided", "that")})

#: Irregular forms -> lemma.
_IRREGULAR = {
    "took": "take", "taken": "take", "broke": "break", "broken": "break", "tore": "tear",
    "torn": "tear", "gave": "give", "given": "give", "fell": "fall", "fallen": "fall",
    "got": "get", "gotten": "get", "threw": "throw", "thrown": "throw", "drew": "draw",
    "drawn": "draw", "stole": "steal", "stolen": "steal", "sold": "sell", "shook": "shake",
    "caved": "cave", "went": "go", "goes": "go", "blew": "blow", "blown": "blow",
    "hauled": "haul", "ripped": "rip", "dragged": "drag", "wheeled": "wheel",
}  # fmt: skip

#: Verbs that remove or destroy their object (or subject, in the passive) on their own.
_REMOVE_ALONE = frozenset({
    "remove", "delete", "eliminate", "disappear", "vanish", "dismantle", "disassemble",
    "demolish", "destroy", "uninstall", "detach", "unmount", "steal", "sell", "discard",
    "collapse", "crumble", "break", "shatter", "snap", "buckle", "topple", "smash",
    "evaporate", "relocate", "displace", "extract", "withdraw", "erase", "obliterate",
    "scrap", "trash", "ditch", "donate", "missing", "absent", "gone",
})  # fmt: skip
#: Verbs of moving that remove only with a particle ("take away", "drag out").
_MOVE = frozenset({
    "take", "drag", "haul", "rip", "pull", "tear", "carry", "move", "lift", "yank", "wheel",
    "push", "cart", "clear", "throw", "toss", "knock", "kick", "slide", "shift", "draw",
    "get", "tow", "roll", "hoist", "heave", "pry", "wrench", "chop", "cut", "saw", "blow",
    "wash", "sweep", "shove", "bring", "put", "load", "lug", "scoot",
})  # fmt: skip
_AWAY = frozenset({"away", "out", "off", "down", "over", "aside", "apart"})
#: Collapse with a particle or object: "give way", "cave in", "fall apart", "tip over".
_COLLAPSE_2 = frozenset({("give", "way"), ("cave", "in"), ("fall", "apart"),
                         ("tip", "over"), ("fall", "down"), ("fall", "over"),
                         ("break", "down"), ("go", "away"), ("get", "rid"),
                         ("no", "longer"), ("not", "there"), ("were", "not"),
                         ("was", "not")})  # fmt: skip
#: Words said of the agent of a removal, never what is removed.
AGENTS = frozenset({"someone", "somebody", "anyone", "anybody", "we", "i", "you", "they",
                    "he", "she", "people", "person", "me", "us", "them", "one",
                    "ever"})  # fmt: skip


def lemma(word: str) -> str:
    """A verb form's lemma, by the irregular table and the regular suffixes.

    >>> [lemma(w) for w in ("drags", "ripped", "collapsing", "removed", "carries", "gave")]
    ['drag', 'rip', 'collapse', 'remove', 'carry', 'give']
    """
    if word in _IRREGULAR:
        return _IRREGULAR[word]
    for suffix, repl in (("ies", "y"), ("ied", "y")):
        if word.endswith(suffix) and len(word) > 4:
            return word[: -len(suffix)] + repl
    known = _REMOVE_ALONE | _MOVE | _FALLING | {w for w, _ in _COLLAPSE_2}
    if word in known:
        return word
    for suffix in ("ing", "ed", "es", "s", "d"):
        if word.endswith(suffix) and len(word) > len(suffix) + 2:
            stem = word[: -len(suffix)]
            for cand in (stem, stem + "e", stem[:-1] if stem[-1:] == stem[-2:-1] else stem):
                if cand in known:
                    return cand
    return word


def removes(tokens: tuple[str, ...]) -> bool:
    """Whether a clause says that something is removed or gives way.

    >>> removes(("the", "tub", "is", "ripped", "out"))
    True
    >>> removes(("i", "take", "the", "lamp")), removes(("we", "haul", "the", "dresser", "away"))
    (False, True)
    >>> removes(("you", "are", "looking", "at", "the", "2", "trash", "cans"))
    False
    """
    lemmas = [lemma(t) for t in tokens]
    for i, lem in enumerate(lemmas):
        if lem in _REMOVE_ALONE and not (i > 0 and _counts_or_determines(tokens[i - 1])):
            return True  # not a noun after its determiner ("the trash can", "2 trash cans")
        if lem == "go" and i == len(tokens) - 1 and i > 0:
            return True  # "when the table goes": said of a thing, going is leaving
        nxt = lemmas[i + 1] if i + 1 < len(lemmas) else ""
        if (lem, nxt) in _COLLAPSE_2 or (tokens[i], nxt) in _COLLAPSE_2:
            return True
        if lem in _MOVE and any(t in _AWAY for t in tokens[i + 1 : i + 6]):
            return True
    return False


def _counts_or_determines(word: str) -> bool:
    """A determiner or a number: what stands before a noun, never before a verb."""
    return word in DETERMINERS or word in NUMBER_WORDS or word.isdigit()


#: Auxiliaries and particles of a removal clause ("is", "were", "to be", "rid of").
_AUXILIARIES = frozenset({"is", "are", "was", "were", "be", "been", "being", "gets", "got",
                          "get", "would", "will", "could", "can", "did", "do", "does", "to",
                          "rid", "of", "way", "no", "longer", "not", "there", "suddenly",
                          "just", "ever", "somehow", "completely", "entirely", "fully",
                          "had", "has", "have", "then", "away", "aside", "apart"})  # fmt: skip


def _names_removed(clause: tuple[str, ...], k: int) -> bool:
    """Whether the clause's word ``k`` may name what is removed: not an agent, an auxiliary
    or a verb, unless a noun: after a determiner or a number ("the trash"), or "can" or
    "cans" after one ("the trash can", "two trash cans"; the modal's subject has no
    determiner right before the modal's noun)."""
    t = clause[k]
    noun_after_determiner = k > 0 and _counts_or_determines(clause[k - 1])
    if t in ("can", "cans") and k > 1 and _counts_or_determines(clause[k - 2]):
        return True
    if t in AGENTS or t in _AUXILIARIES:
        return False
    return not _verb(t) or noun_after_determiner


def _verb(word: str) -> bool:
    """A word of removal or collapse (any form), or one of their particles."""
    lem = lemma(word)
    return (
        lem in _REMOVE_ALONE
        or lem in _MOVE
        or word in _AWAY
        or lem in ("give", "cave", "fall", "tip", "go")
    )


#: Verbs that open an inverted condition before their subject's determiner ("were the
#: shelf to snap", "had the bed been removed", "should the table break").
_INVERTED = frozenset({"were", "had", "should"})


def _opener(tokens: tuple[str, ...], i: int) -> int:
    """Length of a condition opener at ``tokens[i]`` (0 when there is none)."""
    if i + 1 < len(tokens) and (tokens[i], tokens[i + 1]) in _OPENERS_2:
        return 2
    if tokens[i] in _INVERTED and i + 1 < len(tokens) and tokens[i + 1] in DETERMINERS:
        return 1  # the clause must still remove something (split_condition)
    return 1 if tokens[i] in SUBORDINATORS else 0


#: Words that open the question after a condition written without a comma ("if the
#: table is removed what falls").
_QUESTION_WORDS = frozenset({"what", "which", "who", "whom", "whose", "how", "where"})


def _question_start(clause: tuple[str, ...]) -> int:
    """Where a question begins inside a condition clause that no comma closes: the first
    question word after the words of removal; the clause's length when there is none."""
    for k in range(1, len(clause)):
        if clause[k] in _QUESTION_WORDS and removes(clause[:k]):
            return k
    return len(clause)


#: Verbs of a question that asks what falls (their lemmas), for "without X".
_FALLING = frozenset({"fall", "drop", "tumble", "topple", "crash", "slide", "slip", "hang",
                      "lose", "collapse", "tip"})  # fmt: skip


def _without(tokens: tuple[str, ...]) -> tuple[tuple[str, ...], tuple[str, ...]] | None:
    """``(what is removed, the question)`` for "without X" in a question of what falls."""
    if "without" not in tokens or not any(t in _QUESTION_WORDS for t in tokens):
        return None
    i = tokens.index("without")
    end = next((j for j in range(i + 1, len(tokens)) if tokens[j] in (",", ".", "?")),
               len(tokens))  # fmt: skip
    question = (*tokens[:i], *tokens[end:])
    if not tokens[i + 1 : end] or not any(lemma(t) in _FALLING for t in question):
        return None
    return tokens[i + 1 : end], tuple(t for k, t in enumerate(question) if t != "," or k > 0)


#: Words of a question that asks what follows a removal ("what happens?", "what is
#: affected?", "what is left standing?", "what stays up?").
_FOLLOWS = frozenset({"happen", "happens", "happened", "affect", "affected", "affects",
                      "left", "remain", "remains", "stay", "stays", "standing",
                      "support", "supported", "unsupported"})  # fmt: skip
#: Verbs of motion that fall with "down" ("what comes down?", "what goes down with it?").
_DOWN = frozenset(
    {
        "come",
        "comes",
        "came",
        "coming",
        "go",
        "goes",
        "went",
        "going",
        "crash",
        "crashes",
        "crashed",
        "crashing",
        "bring",
        "brings",
        "brought",
    }
)


def moves_away(word: str) -> bool:
    """Whether a word is a verb of removal, or of moving that removes with a particle
    ("remove", "take", "hauled")."""
    return lemma(word) in _REMOVE_ALONE or lemma(word) in _MOVE


def asks_what_follows(question: tuple[str, ...]) -> bool:
    """Whether a question asks what falls or what happens after a removal.

    >>> asks_what_follows(tuple("what comes down with it ?".split()))
    True
    >>> asks_what_follows(tuple("which things are affected ?".split()))
    True
    >>> asks_what_follows(tuple("which one is it ?".split()))
    False
    """
    return any(
        t in _FOLLOWS or lemma(t) in _FALLING or (t in _DOWN and nxt == "down")
        for t, nxt in zip(question, (*question[1:], ""), strict=True)
    )


def _stated(tokens: tuple[str, ...]) -> tuple[tuple[str, ...], tuple[str, ...]] | None:
    """``(what is removed, the question)`` for a removal stated first, then a question of
    what follows, with no word of condition ("the shelf gives way, what comes down with
    it?", "we haul the dresser away what drops"): the statement is the condition."""
    for k in range(1, len(tokens)):
        if tokens[k] not in _QUESTION_WORDS:
            continue
        statement = tuple(t for t in tokens[:k] if t != ",")
        if not statement or not removes(statement):
            continue
        question = tokens[k:]
        if not asks_what_follows(question):
            return None
        kept = tuple(t for k, t in enumerate(statement) if _names_removed(statement, k))
        return (kept, question) if kept else None
    return None


def split_condition(
    tokens: tuple[str, ...],
) -> tuple[tuple[str, ...], tuple[str, ...]] | None:
    """``(what the condition removes, the question)`` when ``tokens`` hold a condition
    clause of removal or collapse, else ``None``.

    The condition runs from its opener to the next comma or sentence end; the question is
    everything else. Agents ("someone", "we"), auxiliaries and the words of removal are
    left out of the condition: what is left names what is removed."""
    for i, width, start, end in _clauses(tokens):
        clause = tokens[start:end]
        if not clause or not removes(clause):
            continue
        end = start + _question_start(clause)
        clause = tokens[start:end]
        question = _question(tokens, i, width, end)
        kept = tuple(t for k, t in enumerate(clause) if _names_removed(clause, k))
        return _or_named(kept, question), question
    return _without(tokens) or _stated(tokens)


def _clauses(tokens: tuple[str, ...]) -> Iterator[tuple[int, int, int, int]]:
    """Each condition clause of ``tokens``: ``(i, width, start, end)``, its opener at ``i``
    (``width`` tokens) and its words ``tokens[start:end]``, up to the next comma or
    sentence end."""
    n = len(tokens)
    for i in range(n):
        width = _opener(tokens, i)
        if not width:
            continue
        if tokens[i] == "should" and i > 0 and tokens[i - 1] not in (",", ".", "?"):
            continue  # "what should fall": not an inverted condition
        start = i + width
        yield i, width, start, next((j for j in range(start, n) if tokens[j] in (",", ".", "?")), n)


def _question(tokens: tuple[str, ...], i: int, width: int, end: int) -> tuple[str, ...]:
    """The tokens outside the condition clause opened at ``i`` and ending at ``end`` (the
    "what" of "what if" kept), without a comma left at their start."""
    question = (*tokens[: i if width == 1 or tokens[i] != "what" else i + 1], *tokens[end:])
    return tuple(t for k, t in enumerate(question) if t != "," or k > 0)


def _or_named(kept: tuple[str, ...], question: tuple[str, ...]) -> tuple[str, ...]:
    """What a condition names, or, when it says only "it", the thing the question names
    ("what goes down with the desk if it collapses?": the desk)."""
    if kept and all(t in PRONOUNS for t in kept):
        return _named_in(question) or kept
    return kept


#: Verbs that move a thing without taking it away ("if I lift the tray", "once we push the
#: cart"): what rests on it goes along.
_CARRY = frozenset({"move", "lift", "pick", "push", "carry", "slide", "shift", "raise",
                    "tilt", "drag", "roll", "wheel", "rotate", "turn", "relocate",
                    "transport"})  # fmt: skip
#: Verbs of a question of what goes along with a moved thing ("what moves with it?", "what
#: comes along?", "what would go with it?").
_ALONG = frozenset({"move", "moves", "moved", "moving", "come", "comes", "came", "coming",
                    "go", "goes", "went", "going", "travel", "travels", "ride", "rides",
                    "follow", "follows", "shift", "shifts", "slide", "slides"})  # fmt: skip


def asks_what_goes_along(question: tuple[str, ...]) -> bool:
    """Whether a question asks what goes along with something moved.

    >>> asks_what_goes_along(tuple("what moves with it ?".split()))
    True
    >>> asks_what_goes_along(tuple("what comes along ?".split()))
    True
    >>> asks_what_goes_along(tuple("what is near it ?".split()))
    False
    """
    for k, t in enumerate(question):
        if t in _ALONG and any(w in ("with", "along") for w in question[k + 1 : k + 5]):
            return True
    return False


def split_carried(
    tokens: tuple[str, ...],
) -> tuple[tuple[str, ...], tuple[str, ...]] | None:
    """``(what the condition moves, the question)`` when ``tokens`` hold a condition clause
    that moves something without removing it and a question of what goes along with it,
    in either order ("if I lift the tray, what moves with it?", "what comes along if we
    push the cart?"), else ``None``. An "it" in the condition is the thing the question
    names ("what moves with the tray if I lift it?").

    >>> split_carried(tuple("if i lift the tray , what moves with it ?".split()))
    (('the', 'tray'), ('what', 'moves', 'with', 'it', '?'))
    >>> split_carried(tuple("what moves with the tray if i lift it ?".split()))
    (('the', 'tray'), ('what', 'moves', 'with', 'the', 'tray', '?'))
    >>> split_carried(tuple("if i lift the tray , what is under it ?".split())) is None
    True
    """
    for i, width, start, end in _clauses(tokens):
        clause = tokens[start:end]
        if not any(lemma(t) in _CARRY for t in clause) or removes(clause):
            continue
        question = _question(tokens, i, width, end)
        if not asks_what_goes_along(question):
            return None
        kept = tuple(t for t in clause if t not in AGENTS and t not in _AUXILIARIES
                     and lemma(t) not in _CARRY and t not in ("up", "over", "around"))  # fmt: skip
        kept = _or_named(kept, question) if kept else _named_in(question)
        return (kept, question) if kept else None
    return None


def _named_in(question: tuple[str, ...]) -> tuple[str, ...]:
    """The words of the question's first definite noun phrase ("the desk" of "what goes
    down with the desk"), up to the next punctuation; empty when it has none."""
    start = next((k for k, t in enumerate(question) if t in DEFINITE), None)
    if start is None:
        return ()
    end = next((j for j in range(start, len(question)) if question[j] in (",", ".", "?")),
               len(question))  # fmt: skip
    return question[start:end]
