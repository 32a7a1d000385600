"""Scoring texts by meaning: what the grounding stage compares an instruction with.

Two scorers share one small interface (:class:`MeaningScorer`): ``scores(query, texts)``
gives one number per text, higher for closer meaning.

* :class:`EmbeddingMeaning` (the ``embed`` extra): cosine similarity of MiniLM sentence
  embeddings. The descriptions of the shipped knowledge table are embedded ahead of time
  (``data/knowledge_vectors.npz``, made by ``scripts/make_knowledge_vectors.py`` with the
  same model, stored as int8 codes with a scale per row), so a cold ``ask`` embeds only
  the instruction and the few descriptions the table does not hold (the name and WordNet
  definition of a label the table knows only as another name or not at all, stored
  attributes).
* :class:`LexicalMeaning` (always available): a Dice coefficient over content words,
  where two words count with the strength of their WordNet relation (same word 1.0,
  synonym 0.8, derivation 0.7, hypernym 0.5; see
  :func:`causalsplat.reason.affordance.lexical_score`).

>>> from causalsplat.reason.lexicon import load_lexicon
>>> scorer = LexicalMeaning(load_lexicon())
>>> [round(float(s), 2) for s in scorer.scores("I want to sleep", ["sleep in", "cook food"])]
[0.67, 0.0]
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from functools import lru_cache
from importlib import resources
from typing import Any, Protocol

import numpy as np

from causalsplat.reason._text import tokenize
from causalsplat.reason.affordance import lexical_score
from causalsplat.reason.lexicon import Lexicon

#: The model the shipped description vectors were made with.
VECTORS_MODEL = "all-MiniLM-L6-v2"


class MeaningScorer(Protocol):
    """Scores texts against a query by meaning (higher is closer)."""

    method: str

    def scores(self, query: str, texts: Sequence[str]) -> np.ndarray:
        """``(len(texts),)`` float64 scores."""
        ...


class LexicalMeaning:
    """Word overlap weighted by WordNet relatedness (module docstring)."""

    method = "lexical"

    def __init__(self, lexicon: Lexicon) -> None:
        self.lexicon = lexicon

    def scores(self, query: str, texts: Sequence[str]) -> np.ndarray:
        words = [t for t in tokenize(query) if t.isalnum()]
        return np.asarray(
            [lexical_score(words, " ".join(tokenize(t)), self.lexicon) for t in texts],
            dtype=np.float64,
        )


class EmbeddingMeaning:
    """Cosine similarity of sentence embeddings (module docstring)."""

    method = "embedding"

    def __init__(self, embedder: Any) -> None:
        self.embedder = embedder
        shipped = shipped_vectors()
        self._shipped: dict[str, np.ndarray] = {}
        if shipped is not None:
            self._shipped = dict(zip(shipped[0], shipped[1], strict=True))

    def vectors(self, texts: Sequence[str]) -> np.ndarray:
        """``(len(texts), 384)`` unit vectors: the shipped ones where the table has the
        text, the model's otherwise."""
        missing = [t for t in dict.fromkeys(texts) if t not in self._shipped]
        computed = dict(zip(missing, self.embedder.encode(missing), strict=True))
        rows = [self._shipped[t] if t in self._shipped else computed[t] for t in texts]
        return np.stack(rows).astype(np.float64) if rows else np.zeros((0, 384))

    def scores(self, query: str, texts: Sequence[str]) -> np.ndarray:
        if not texts:
            return np.zeros(0, dtype=np.float64)
        q = np.asarray(self.embedder.encode([query])[0], dtype=np.float64)
        return self.vectors(texts) @ q


def vectors_path() -> Any:
    return resources.files("causalsplat.reason").joinpath("data", "knowledge_vectors.npz")


def texts_digest(texts: Sequence[str]) -> str:
    """SHA-256 of the texts, one per line: ties a vectors file to the table it embeds."""
    return hashlib.sha256("\n".join(texts).encode("utf-8")).hexdigest()


@lru_cache(maxsize=1)
def shipped_vectors() -> tuple[tuple[str, ...], np.ndarray] | None:
    """The shipped ``(texts, vectors)`` (float32 unit rows), or ``None`` when absent."""
    path = vectors_path()
    if not path.is_file():
        return None
    with path.open("rb") as handle, np.load(handle, allow_pickle=False) as data:
        if str(data["model"]) != VECTORS_MODEL:
            return None
        texts = tuple(str(t) for t in data["texts"])
        vectors = data["codes"].astype(np.float32) * data["scale"].astype(np.float32)
    norms = np.linalg.norm(vectors, axis=1, keepdims=True)
    return texts, vectors / np.maximum(norms, 1e-12)
