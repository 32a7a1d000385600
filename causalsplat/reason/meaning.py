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
  The instruction's vector is first moved by the *need adapter*
  (:class:`QueryAdapter`, ``data/need_adapter.npz``), a low-rank linear correction learned
  on the train split of the DDN demand instructions by ``scripts/train_need_adapter.py``:
  a general sentence model puts a need near the objects it mentions more than near the
  objects that meet it. ``EmbeddingMeaning(embedder, adapter=None)`` scores without it.
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

    def scores(self, query: str, texts: Sequence[str], *, need: bool = True) -> np.ndarray:
        """``(len(texts),)`` float64 scores. ``need``: the query is what an instruction
        asks for (a need adapter applies); ``False`` for a noun phrase ("the oven")."""
        ...

    def table_scores(self, query: str) -> tuple[tuple[str, ...], np.ndarray] | None:
        """Every category of the shipped knowledge table scored against a need (the mean
        of its two best descriptions, as a scene's categories are scored): what would
        meet it best anywhere, the reference a scene's best is held to. ``None`` when the
        scorer has no vectors of the table."""
        ...


class LexicalMeaning:
    """Word overlap weighted by WordNet relatedness (module docstring)."""

    method = "lexical"

    def __init__(self, lexicon: Lexicon) -> None:
        self.lexicon = lexicon

    def scores(self, query: str, texts: Sequence[str], *, need: bool = True) -> np.ndarray:
        words = [t for t in tokenize(query) if t.isalnum()]
        return np.asarray(
            [lexical_score(words, " ".join(tokenize(t)), self.lexicon) for t in texts],
            dtype=np.float64,
        )

    def table_scores(self, query: str) -> tuple[tuple[str, ...], np.ndarray] | None:
        """``None``: word overlap over the whole table is too slow to be a reference."""
        return None


class QueryAdapter:
    """``q -> normalise(q + U (V^T q))``: the need adapter (module docstring).

    >>> import numpy as np
    >>> u = np.zeros((384, 2), np.float32); v = np.zeros((384, 2), np.float32)
    >>> q = np.eye(384, dtype=np.float32)[:1]
    >>> bool(np.allclose(QueryAdapter(u, v)(q), q))
    True
    """

    def __init__(self, u: np.ndarray, v: np.ndarray, *, digest: str = "") -> None:
        if u.shape != v.shape or u.ndim != 2:
            raise ValueError(
                f"U and V must have one shape (dim, rank), got {u.shape} and {v.shape}"
            )
        self.u = np.asarray(u, dtype=np.float64)
        self.v = np.asarray(v, dtype=np.float64)
        self.digest = digest

    @property
    def rank(self) -> int:
        return int(self.u.shape[1])

    def __call__(self, q: np.ndarray) -> np.ndarray:
        """``(n, dim)`` unit rows (or one ``(dim,)`` vector) moved and normalised again."""
        x = np.asarray(q, dtype=np.float64)
        out = x + (x @ self.v) @ self.u.T
        return out / np.maximum(np.linalg.norm(out, axis=-1, keepdims=True), 1e-12)


class EmbeddingMeaning:
    """Cosine similarity of sentence embeddings (module docstring).

    ``adapter``: ``"shipped"`` (default) moves an instruction's vector by the shipped need
    adapter when the package holds one (not a noun phrase's: ``scores(..., need=False)``);
    ``None`` scores with the model's vectors alone.
    """

    method = "embedding"

    def __init__(self, embedder: Any, adapter: QueryAdapter | str | None = "shipped") -> None:
        self.embedder = embedder
        if adapter == "shipped":
            adapter = shipped_adapter()
        elif isinstance(adapter, str):
            raise ValueError(f"adapter must be 'shipped', None or a QueryAdapter, got {adapter!r}")
        self.adapter: QueryAdapter | None = adapter
        shipped = shipped_vectors()
        self._shipped: dict[str, np.ndarray] = {}
        self._table: _Table | None = None
        if shipped is not None:
            self._shipped = dict(zip(shipped[0], shipped[1], strict=True))
            self._table = _Table.of(*shipped)
        self._queries: dict[tuple[str, bool], np.ndarray] = {}

    def vectors(self, texts: Sequence[str]) -> np.ndarray:
        """``(len(texts), 384)`` unit vectors: the shipped ones where the table has the
        text, the model's otherwise."""
        missing = [t for t in dict.fromkeys(texts) if t not in self._shipped]
        computed = dict(zip(missing, self.embedder.encode(missing), strict=True))
        rows = [self._shipped[t] if t in self._shipped else computed[t] for t in texts]
        return np.stack(rows).astype(np.float64) if rows else np.zeros((0, 384))

    def query_vector(self, query: str, *, need: bool = True) -> np.ndarray:
        """The query's unit vector (moved by the need adapter for a need); the last few
        are kept, since one instruction is scored against several sets of texts."""
        key = (query, need)
        q = self._queries.get(key)
        if q is None:
            q = np.asarray(self.embedder.encode([query])[0], dtype=np.float64)
            if need and self.adapter is not None:
                # the adapter was learned on instructions; a noun phrase keeps its own vector
                q = self.adapter(q)
            if len(self._queries) >= 64:
                self._queries.clear()
            self._queries[key] = q
        return q

    def scores(self, query: str, texts: Sequence[str], *, need: bool = True) -> np.ndarray:
        if not texts:
            return np.zeros(0, dtype=np.float64)
        return self.vectors(texts) @ self.query_vector(query, need=need)

    def table_scores(self, query: str) -> tuple[tuple[str, ...], np.ndarray] | None:
        if self._table is None:
            return None
        return self._table.names, self._table.best_two(self.query_vector(query, need=True))


class _Table:
    """The shipped descriptions grouped by category (a text ``"name: ..."`` or the bare
    name belongs to ``name``), for scoring every category at once."""

    def __init__(self, names: tuple[str, ...], vectors: np.ndarray, starts: np.ndarray) -> None:
        self.names = names
        self.vectors = vectors
        self.starts = starts

    @classmethod
    def of(cls, texts: Sequence[str], vectors: np.ndarray) -> _Table:
        owners = np.asarray([t.split(":", 1)[0].strip() for t in texts])
        order = np.argsort(owners, kind="stable")
        owners = owners[order]
        starts = np.flatnonzero(np.r_[True, owners[1:] != owners[:-1]])
        names = tuple(str(n) for n in owners[starts])
        return cls(names, np.asarray(vectors, dtype=np.float64)[order], starts)

    def best_two(self, q: np.ndarray) -> np.ndarray:
        """Per category, the mean of its two best scores (its one score when alone)."""
        s = self.vectors @ q
        ends = np.r_[self.starts[1:], len(s)]
        group = np.repeat(np.arange(len(self.starts)), ends - self.starts)
        ranked = s[np.lexsort((s, group))]  # each group's scores, ascending
        first = ranked[ends - 1]
        second = np.where(ends - self.starts > 1, ranked[np.maximum(ends - 2, 0)], first)
        return 0.5 * (first + second)


def vectors_path() -> Any:
    return resources.files("causalsplat.reason").joinpath("data", "knowledge_vectors.npz")


def adapter_path() -> Any:
    return resources.files("causalsplat.reason").joinpath("data", "need_adapter.npz")


@lru_cache(maxsize=1)
def shipped_adapter() -> QueryAdapter | None:
    """The shipped need adapter, or ``None`` when absent or made for another model."""
    path = adapter_path()
    if not path.is_file():
        return None
    with path.open("rb") as handle, np.load(handle, allow_pickle=False) as data:
        if str(data["model"]) != VECTORS_MODEL:
            return None
        return QueryAdapter(data["u"], data["v"], digest=str(data["digest"]))


def shipped_digest() -> str:
    """The digest of the shipped knowledge vectors' texts (``""`` when absent)."""
    path = vectors_path()
    if not path.is_file():
        return ""
    with path.open("rb") as handle, np.load(handle, allow_pickle=False) as data:
        return str(data["digest"])


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
