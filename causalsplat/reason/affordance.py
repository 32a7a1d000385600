"""Which affordances an action or need refers to ("where can I wash my hands?").

Candidates are the scene's stored affordance values (attribute key ``affordance``, e.g. from
an objects file or the VLM labeler) or, when the scene stores none, the lexicon's
affordances of its categories. Each candidate phrase is scored against the action words:

* lexical (always): a Dice coefficient over content words, where a pair of words counts
  with the strength of their WordNet relation (:meth:`Lexicon.related_words`: same word
  1.0, synonym 0.8, derivation 0.7, hypernym 0.5), e.g. "put things" vs "place items";
* with an embedding model: the cosine similarity of the sentence embeddings of the action
  and of the phrase, averaged with the lexical score.

Every candidate within ``tie`` of the best score is kept (several phrases may share the
best score), when the best is at least ``minimum``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from causalsplat.reason._grammar import ACTION_STOPWORDS
from causalsplat.reason.embed import TextEmbedder
from causalsplat.reason.lexicon import Lexicon

#: Words meaning "some object", compared as one word.
_GENERIC = {"thing": "item", "things": "item", "stuff": "item", "items": "item",
            "objects": "item", "object": "item", "belongings": "item"}  # fmt: skip


@dataclass(frozen=True, slots=True)
class AffordanceMatch:
    """The affordance phrases chosen for an action, with every candidate's score."""

    phrases: tuple[str, ...]
    scores: tuple[tuple[str, float], ...]
    method: str


def _content(words: Sequence[str], lexicon: Lexicon) -> list[str]:
    out = []
    for w in words:
        w = _GENERIC.get(w, w)
        if w in ACTION_STOPWORDS and w not in ("in", "on", "from", "with"):
            continue
        out.append(w)
    return out


def _word_similarity(a: str, b: str, lexicon: Lexicon, memo: dict[str, dict[str, float]]) -> float:
    if a == b:
        return 1.0
    ra = memo.setdefault(a, lexicon.related_words(a))
    rb = memo.setdefault(b, lexicon.related_words(b))
    return max(ra.get(b, 0.0), rb.get(a, 0.0))


def lexical_score(action: Sequence[str], phrase: str, lexicon: Lexicon) -> float:
    """Dice coefficient of the content words, weighted by WordNet relatedness."""
    q = _content(action, lexicon)
    p = _content(phrase.split(), lexicon)
    if not q or not p:
        return 0.0
    memo: dict[str, dict[str, float]] = {}
    matched = sum(max(_word_similarity(w, v, lexicon, memo) for w in q) for v in p)
    return 2.0 * matched / (len(p) + len(q))


def match_affordances(
    action: Sequence[str],
    candidates: Sequence[str],
    lexicon: Lexicon,
    *,
    embedder: TextEmbedder | None = None,
    minimum: float = 0.3,
    tie: float = 1e-9,
) -> AffordanceMatch:
    """Score ``candidates`` against ``action`` (module docstring)."""
    unique = sorted(set(candidates))
    scores = {c: lexical_score(action, c, lexicon) for c in unique}
    method = "lexical"
    if embedder is not None and unique:
        cosine = embedder.similarities(" ".join(action), unique)
        scores = {c: 0.5 * scores[c] + 0.5 * max(0.0, s) for c, s in zip(unique, cosine)}
        method = "lexical+embedding"
    if not scores:
        return AffordanceMatch((), (), method)
    best = max(scores.values())
    ranked = tuple(sorted(scores.items(), key=lambda kv: (-kv[1], kv[0])))
    if best < minimum:
        return AffordanceMatch((), ranked, method)
    chosen = tuple(sorted(c for c, s in scores.items() if s >= best - tie))
    return AffordanceMatch(chosen, ranked, method)
