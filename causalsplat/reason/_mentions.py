"""Which words of an instruction name which categories of the scene.

:class:`CategoryIndex` maps noun phrases (head in base form) to the scene's categories
with a score: the category's own name 1.0 (``kitchen cabinets`` from ``kitchen cabinet``),
its run-together spelling 1.0 (``bookshelf`` for ``book shelf``), a WordNet synonym 0.9
(``couch`` for ``sofa``; only a synonym whose most frequent sense is the category's, so
``can`` does not name a toilet), its head noun alone 0.8 (``cabinet`` for ``kitchen
cabinets``), another name the knowledge table gives its kind 0.75 (``wastebasket`` for
``trash can``), a WordNet hypernym within three steps 0.5 minus 0.05 a step
(``furniture``, ``seat``). Phrases it does not hold are resolved through WordNet the other
way (a hyponym of a category, ``armchair`` -> ``chair``: 0.6) or by spelling (trigram
similarity >= 0.8 with a category: 0.6, so ``refrigerator`` finds ScanNet's
``refridgerator``).
"""

from __future__ import annotations

import functools
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from causalsplat.colors import WORDS as COLOUR_WORDS
from causalsplat.colors import is_color_word
from causalsplat.reason._grammar import (
    CLOSED_CLASS,
    DETERMINERS,
    EXTREMES,
    FUNCTION_WORDS,
    GENERIC_TARGETS,
    INFINITIVE_HEADS,
    SIDES,
    SPATIAL_NOUNS,
)
from causalsplat.reason._text import NUMBER_WORDS, tokenize
from causalsplat.reason.lexicon import Lexicon
from queries.semantics import text_similarity

MAX_PHRASE = 4
#: Lowest lexicon score of a mention that names a category (name 1.0, base form 0.98,
#: synonym 0.9, head noun 0.8; hypernyms and foreign nouns score 0.6 or less): below it,
#: a phrase names a category only by another name or by meaning.
NAMED = 0.8
#: Another name the knowledge table gives the category's kind ("wastebasket" for
#: ``trash can``): below a head noun, and below what a need counts as named outright
#: (:data:`NAMED`): "store tissues" asks for what holds tissues, and scoring the tissue
#: box as what the need acts on (as 0.9 did) cost DDN train 1.4 points.
ALIAS = 0.75
_HYPERNYM_DEPTH = 3
#: Hypernyms too general to name anything.
_TOO_GENERAL = frozenset({
    "artifact", "artefact", "whole", "unit", "object", "physical object", "instrumentality",
    "instrumentation", "device", "structure", "construction", "commodity", "goods",
    "consumer goods", "thing", "part", "portion", "material", "stuff", "implement", "article",
    "covering", "surface", "container", "equipment", "system", "support", "protective covering",
    "creation", "decoration", "ornament", "means", "facility", "installation", "mechanism",
    "fixture", "electronic equipment", "durable", "durable goods", "consumer durables",
    "furnishing", "fabric", "cloth", "textile", "solid", "matter", "substance",
})  # fmt: skip


@dataclass(frozen=True, slots=True)
class Mention:
    """A noun phrase of the instruction, tokens ``[start, end)``.

    ``categories``: the scene categories it names (all with the best score), empty when it
    names none; ``generic``: a word like "one" or "thing" that stands for any entity;
    ``plural``: the head noun was plural; ``phrase``: the phrase as read (head in base form).
    """

    start: int
    end: int
    phrase: str
    categories: tuple[str, ...]
    score: float
    generic: bool = False
    plural: bool = False


class CategoryIndex:
    """Noun phrases -> scene categories with scores (module docstring)."""

    def __init__(
        self,
        categories: tuple[str, ...],
        lexicon: Lexicon,
        attribute_words: frozenset[str] = frozenset(),
        aliases: Mapping[str, Iterable[str]] | None = None,
    ) -> None:
        self.lexicon = lexicon
        self.categories = categories
        self.attribute_words = attribute_words
        self.entries: dict[str, dict[str, float]] = {}
        self._sense_of: dict[int, list[str]] = {}
        self._lemma_of: dict[str, str] = {}
        for category in categories:
            self._add_category(category)
            for alias in (aliases or {}).get(category, ()):
                words = tokenize(alias)
                self._put(" ".join(words), category, ALIAS)
                self._put(lexicon.phrase_lemma(words), category, ALIAS)

    @functools.cached_property
    def spelling_vocabulary(self) -> frozenset[str]:
        """The words a misspelling is corrected to (:mod:`~causalsplat.reason._spelling`):
        those of the scene's category names, colour names and side and size words."""
        words = {w for c in self.categories for w in c.split()}
        return frozenset(words | set(COLOUR_WORDS) | set(SIDES) | set(EXTREMES))

    def is_word(self, word: str) -> bool:
        """Whether ``word`` is a word, never a misspelling: an English word WordNet knows,
        a function word, or (with a plural ``s``) a word of the scene's category names."""
        if word in CLOSED_CLASS or self.lexicon.is_word(word):
            return True
        return word.endswith("s") and word[:-1] in self.spelling_vocabulary

    def _put(self, phrase: str, category: str, score: float) -> None:
        if not phrase:
            return
        slot = self.entries.setdefault(phrase, {})
        if slot.get(category, 0.0) < score:
            slot[category] = score

    def _add_category(self, category: str) -> None:
        lex = self.lexicon
        words = tokenize(category)
        if not words:
            return
        lemma = lex.phrase_lemma(words)
        self._lemma_of[category] = lemma
        self._put(" ".join(words), category, 1.0)
        self._put(lemma, category, 0.98)
        if len(words) > 1:
            self._put("".join(words), category, 0.98)
            self._put(lex.lemma(words[-1]), category, 0.8)
        senses = lex.noun_senses(lemma)
        if not senses and len(words) > 1:
            senses = lex.noun_senses(lex.lemma(words[-1]))
            for modifier in lex.noun_senses(words[0])[:1]:  # "computer tower": a computer
                self._sense_of.setdefault(modifier, []).append(category)
        if not senses:
            return
        first = senses[0]
        self._sense_of.setdefault(first, []).append(category)
        for synonym in lex.noun_lemmas(first):
            # a synonym names the category only when that is its own most frequent
            # sense: "can" is a container before it is a toilet
            if lex.noun_senses(synonym)[:1] == (first,):
                self._put(synonym, category, 0.9)
        for hyper, depth in lex.hypernym_closure(first, _HYPERNYM_DEPTH).items():
            if depth == 0:
                continue
            for name in lex.noun_lemmas(hyper):
                # a place or part word names no kind ("room" is a toilet's hypernym)
                if name not in _TOO_GENERAL and name not in SPATIAL_NOUNS:
                    self._put(name, category, 0.55 - 0.05 * depth)

    def lookup(self, words: tuple[str, ...]) -> dict[str, float] | None:
        """Categories named by this phrase as written, or with its head in base form, or
        run together; ``None`` when none. A category spelt exactly as written scores 1.0,
        through its base form 0.98 (``kitchen cabinets`` and ``kitchen cabinet`` are two
        ScanNet categories)."""
        out: dict[str, float] = {}
        raw = " ".join(words)
        for key, factor in ((raw, 1.0), (self.lexicon.phrase_lemma(words), 0.98),
                            ("".join(words), 0.98)):  # fmt: skip
            for category, score in self.entries.get(key, {}).items():
                value = score if key == raw else min(score, factor)
                if out.get(category, 0.0) < value:
                    out[category] = value
        return out or None

    def resolve_foreign(self, phrase: str) -> dict[str, float]:
        """Categories for a noun phrase the index does not hold (module docstring)."""
        out: dict[str, float] = {}
        for sense in self.lexicon.noun_senses(phrase)[:2]:
            for hyper in self.lexicon.hypernym_closure(sense, _HYPERNYM_DEPTH):
                for category in self._sense_of.get(hyper, ()):
                    out[category] = max(out.get(category, 0.0), 0.6)
        for category, lemma in self._lemma_of.items():
            if text_similarity(phrase, lemma) >= 0.8:
                out[category] = max(out.get(category, 0.0), 0.6)
        return out


def _best(found: dict[str, float]) -> tuple[tuple[str, ...], float]:
    if not found:
        return (), 0.0
    top = max(found.values())
    return tuple(sorted(c for c, s in found.items() if s >= top - 1e-9)), top


def _is_noun_word(lex: Lexicon, word: str) -> bool:
    if word in SPATIAL_NOUNS or word in FUNCTION_WORDS or word in EXTREMES or word in SIDES:
        return False
    if word in lex.colors or word in NUMBER_WORDS:
        return False  # "the four white bottles": a count, never the thing counted
    return len(word) > 1 and word.isalpha() and lex.has_noun(lex.lemma(word))


def mention_at(index: CategoryIndex, tokens: tuple[str, ...], i: int) -> Mention | None:
    """The longest mention starting at token ``i`` that names a scene category, or a
    generic target word; ``None`` otherwise (also for one word that is a verb after an
    infinitive's "to": :func:`infinitive_verb_at`)."""
    if tokens[i] in GENERIC_TARGETS:
        return Mention(i, i + 1, tokens[i], (), 0.0, generic=True, plural=tokens[i].endswith("s"))
    if tokens[i] in FUNCTION_WORDS and not _after_determiner(index.lexicon, tokens, i):
        return None  # "where can I": a verb; "the can", "the smaller can": a noun
    for length in range(min(MAX_PHRASE, len(tokens) - i), 0, -1):
        words = tokens[i : i + length]
        if any(w in (",", ".", "?") for w in words):
            continue
        if length == 1 and infinitive_verb_at(index, tokens, i):
            continue  # "I want to shower": the verb, not the shower
        found = index.lookup(words)
        if found:
            cats, score = _best(found)
            head = words[-1]
            plural = index.lexicon.lemma(head) != head
            return Mention(i, i + length, index.lexicon.phrase_lemma(words), cats, score,
                           plural=plural)  # fmt: skip
    return None


def _after_determiner(lex: Lexicon, tokens: tuple[str, ...], i: int) -> bool:
    """Whether a determiner comes before token ``i``, past size and colour words ("the
    can", "the smaller can", "a blue can"): the word is then a noun."""
    j = i - 1
    while j >= 0 and (tokens[j] in EXTREMES or colour_word(lex, tokens[j])):
        j -= 1
    return j >= 0 and tokens[j] in DETERMINERS


def foreign_at(index: CategoryIndex, tokens: tuple[str, ...], i: int) -> Mention | None:
    """A noun (phrase) at ``i`` that WordNet knows but the scene index does not hold,
    resolved through :meth:`CategoryIndex.resolve_foreign` (possibly to nothing). A
    compound WordNet knows that resolves to nothing while a later word of it names a
    category is left to that word ("computer monitor": a monitor)."""
    lex = index.lexicon
    if tokens[i] in FUNCTION_WORDS:
        return None
    for length in range(min(MAX_PHRASE, len(tokens) - i), 1, -1):
        words = tokens[i : i + length]
        if any(w in FUNCTION_WORDS or not w.isalpha() for w in words):
            continue
        lemma = lex.phrase_lemma(words)
        if lex.has_noun(lemma):
            cats, score = _best(index.resolve_foreign(lemma))
            if not cats and any(
                mention_at(index, tokens, j) is not None for j in range(i + 1, i + length)
            ):
                return None  # "computer monitor", "round table": the head names a category
            return Mention(i, i + length, lemma, cats, score)
    if not _is_noun_word(lex, tokens[i]) or infinitive_verb_at(index, tokens, i):
        return None
    if i + 1 < len(tokens) and tokens[i + 1] in _PART_WORDS:
        return None  # a word before a part names no thing: "the vertical side of the table"
    for j in range(i + 1, min(i + 2 + _MODIFIER_GAP, len(tokens))):
        if mention_at(index, tokens, j) is not None:
            # a noun modifying a later one: "office chair", "dresser cabinet", "square
            # gray sofa chair", "the wood burning stove"
            return None
        if not may_modify(lex, tokens[j]):
            break
    lemma = lex.lemma(tokens[i])
    cats, score = _best(index.resolve_foreign(lemma))
    return Mention(i, i + 1, lemma, cats, score, plural=lemma != tokens[i])


#: How many words may stand between a modifying noun and the noun it modifies.
_MODIFIER_GAP = 2
#: Words that end a noun phrase: prepositions, conjunctions, relative words.
_PHRASE_ENDS = frozenset({"of", "on", "in", "at", "with", "by", "for", "from", "into", "onto",
                          "under", "over", "and", "or", "but", "that", "which", "who",
                          "whose", "it", "its", "than", "like"})  # fmt: skip


#: Part words that also modify a head ("the wood *top* table", "the *side* table").
_PART_WORDS = frozenset({"top", "bottom", "side", "front", "back", "corner", "end", "edge"})


def colour_word(lex: Lexicon, word: str) -> bool:
    """Whether ``word`` names a colour (WordNet's colour nouns or a basic colour term)."""
    return word in lex.colors or is_color_word(word)


def may_modify(lex: Lexicon, word: str) -> bool:
    """Whether ``word`` may stand inside a noun phrase before its head ("wood *burning*
    stove", "square *gray* chair")."""
    if colour_word(lex, word) or word in _PART_WORDS:
        return True
    return (
        word.isalpha()
        and word not in FUNCTION_WORDS
        and word not in DETERMINERS
        and word not in _PHRASE_ENDS
    )


def infinitive_verb_at(index: CategoryIndex, tokens: tuple[str, ...], i: int) -> bool:
    """Whether the word at ``i`` is a verb after an infinitive's "to" ("I want to
    shower", "something to iron with"), not a noun naming a category."""
    if i < 2 or tokens[i - 1] != "to" or tokens[i - 2] not in INFINITIVE_HEADS:
        return False
    return bool(index.lexicon.verb_senses(tokens[i]))
