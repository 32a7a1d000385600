"""Embed the knowledge table's descriptions ahead of time (the offline reasoner's cache).

Writes ``causalsplat/reason/data/knowledge_vectors.npz``: every text that
:func:`causalsplat.reason.ground.describe` gives for each entry of the shipped knowledge
table, embedded with the packaged all-MiniLM-L6-v2 model exactly as the reasoner embeds
text at run time, stored as int8 codes with a float16 scale per row (unit vectors once
decoded), with the texts, the model name and the SHA-256 of the texts. A cold ``ask``
then embeds only the instruction. Needs the ``embed`` extra.

Usage::

    python scripts/make_knowledge_vectors.py [-o PATH]

Re-run it whenever the knowledge table or the lexicon changes: a test fails while the
shipped file does not match the texts of the table.
"""

from __future__ import annotations

import argparse
import io
import sys
import time
from pathlib import Path

import numpy as np

OUT = (
    Path(__file__).resolve().parent.parent
    / "causalsplat"
    / "reason"
    / "data"
    / "knowledge_vectors.npz"
)


def knowledge_texts() -> list[str]:
    """The texts to embed, in a fixed order (entries sorted). A scene label that is only
    an entry's other name shares the entry's facts; its name and its WordNet definition are
    embedded at run time (two short texts)."""
    from causalsplat.reason.ground import describe
    from causalsplat.reason.knowledge import load_knowledge
    from causalsplat.reason.lexicon import load_lexicon

    knowledge, lexicon = load_knowledge(), load_lexicon()
    texts: dict[str, None] = {}
    for name in knowledge.names:
        facts = knowledge.get(name)
        assert facts is not None
        texts.update(dict.fromkeys(describe(facts.name, lexicon, knowledge)))
    return list(texts)


def build() -> bytes:
    from causalsplat.reason.embed import MiniLMEmbedder
    from causalsplat.reason.meaning import VECTORS_MODEL, texts_digest

    texts = knowledge_texts()
    embedder = MiniLMEmbedder()
    start = time.perf_counter()
    vectors = embedder.encode(texts)
    # int8 per row (a float16 scale each): the file stays small; cosines move by < 1e-3
    scale = np.abs(vectors).max(axis=1, keepdims=True) / 127.0
    codes = np.round(vectors / np.maximum(scale, 1e-12)).astype(np.int8)
    print(f"embedded {len(texts)} texts in {time.perf_counter() - start:.1f} s", file=sys.stderr)
    buffer = io.BytesIO()
    np.savez_compressed(
        buffer,
        texts=np.asarray(texts),
        codes=codes,
        scale=scale.astype(np.float16),
        model=np.asarray(VECTORS_MODEL),
        digest=np.asarray(texts_digest(texts)),
    )
    return buffer.getvalue()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", type=Path, default=OUT)
    args = parser.parse_args(argv)
    data = build()
    args.output.write_bytes(data)
    print(f"wrote {args.output}: {len(data)} bytes", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
