"""The knowledge table scored at once: each category's mean of its two best descriptions."""

from __future__ import annotations

import numpy as np

from causalsplat.reason.meaning import _Table


def _reference(texts: list[str], vectors: np.ndarray, q: np.ndarray) -> dict[str, float]:
    by: dict[str, list[float]] = {}
    for t, v in zip(texts, vectors, strict=True):
        by.setdefault(t.split(":", 1)[0].strip(), []).append(float(v @ q))
    return {k: (s[0] if len(s) == 1 else float(np.mean(sorted(s)[-2:]))) for k, s in by.items()}


def test_best_two_matches_a_plain_loop_with_ties_and_single_texts() -> None:
    rng = np.random.default_rng(3)
    texts = ["b: one", "a", "a: x", "c", "b: two", "a: y", "b: three", "d: only"]
    vectors = rng.normal(size=(len(texts), 8))
    vectors[5] = vectors[2]  # a tie for category a's best
    table = _Table.of(texts, vectors)
    assert table.names == ("a", "b", "c", "d")
    for _ in range(20):
        q = rng.normal(size=8)
        got = dict(zip(table.names, table.best_two(q), strict=True))
        want = _reference(texts, vectors, q)
        assert got.keys() == want.keys()
        for k in want:
            assert np.isclose(got[k], want[k], rtol=0, atol=1e-12)
