"""DDN demand instructions placed in real ScanNet object tables (written by others).

Reads ``../shared/data/ddn_demands`` (instructions of the Demand-Driven Navigation dataset,
each with the AI2-THOR categories that satisfy it, and the team's map of those categories
to ScanNet labels) and the ScanNet object tables of ``referit3d_scannet_objects`` (see each
folder's ``SOURCE.md``; nothing is copied into the repository). The protocol of
``ddn_demands/SOURCE.md``:

* an instruction is *placeable* when its categories map to at least one ScanNet label;
* its scan is drawn, seeded by the instruction's text, among the scans whose table holds an
  object of an acceptable label and objects of at least :data:`MIN_OTHER_LABELS` other
  labels (walls, floors, ceilings, doors, windows and ``object`` not counted);
* the scan's objects (GT boxes and labels) are ingested as ``causalsplat ingest-objects``
  does and the instruction is asked;
* an answer is **right** when it is non-empty and every object in it has an acceptable
  label. Top-3: one of the first three ranked candidates (categories) is acceptable.

The naive baseline, run on the same placements: every object of the scene label whose
name is nearest to the instruction by MiniLM cosine.

Run ``python -m causalsplat.bench._reasoning_ddn train`` while developing (train split
only; the validation split is for the report).
"""

from __future__ import annotations

import json
import random
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

from causalsplat.bench import _reasoning_referit as ref
from causalsplat.reason.errors import ReasonError
from causalsplat.reason.reasoner import Reasoner
from queries.errors import QueryError

DATA = ref.DATA.parent / "ddn_demands"
SPLITS = {"train": "instruction_train_check.json", "val": "instruction_val_check.json"}
MIN_OTHER_LABELS = 8
#: Labels that do not count towards the variety of a scan.
_NOT_COUNTED = frozenset({"wall", "walls", "floor", "ceiling", "door", "doors", "window",
                          "windows", "object"})  # fmt: skip


@dataclass(frozen=True, slots=True)
class Placement:
    """One instruction in one scan: the labels that answer it."""

    text: str
    scan: str
    acceptable: frozenset[str]


@dataclass(frozen=True, slots=True)
class Outcome:
    placement: Placement
    labels: tuple[str, ...]
    ranked: tuple[str, ...]
    right: bool
    top3: bool
    error: str | None
    seconds: float

    @property
    def empty(self) -> bool:
        return self.error is None and not self.labels


def available() -> bool:
    return DATA.exists() and (ref.DATA / "objects_info").exists()


@lru_cache(maxsize=1)
def scan_labels() -> dict[str, frozenset[str]]:
    """Distinct labels of every scan's object table."""
    out = {}
    for path in sorted((ref.DATA / "objects_info").glob("objects_info_*.json")):
        scan = path.stem.removeprefix("objects_info_")
        out[scan] = frozenset(str(o["label"]) for o in json.loads(path.read_text("utf-8")))
    return out


def placements(split: str) -> tuple[list[Placement], int]:
    """The placeable instructions of a split and the split's size."""
    demands: dict[str, list[str]] = json.loads((DATA / SPLITS[split]).read_text("utf-8"))
    mapping: dict[str, list[str]] = json.loads(
        (DATA / "ai2thor_to_scannet.json").read_text("utf-8")
    )
    scans = scan_labels()
    names = sorted(scans)
    out = []
    for text, categories in demands.items():
        acceptable = frozenset(label for c in categories for label in mapping.get(c, ()))
        if not acceptable:
            continue
        pool = [
            s
            for s in names
            if scans[s] & acceptable
            and len(scans[s] - acceptable - _NOT_COUNTED) >= MIN_OTHER_LABELS
        ]
        if pool:
            scan = random.Random(f"ddn:{text}").choice(pool)
            out.append(Placement(text, scan, acceptable))
    return out, len(demands)


def evaluate(
    rows: Sequence[Placement], reasoner: Reasoner, graphs: ref.ScanGraphs
) -> list[Outcome]:
    """Ask each placed instruction; errors count as wrong answers."""
    out = []
    for row in rows:
        ctx = graphs.context(row.scan)
        start = time.perf_counter()
        error = None
        labels: tuple[str, ...] = ()
        ranked: tuple[str, ...] = ()
        try:
            answer = reasoner.answer(row.text, ctx)
            labels = answer.categories
            ranked = tuple(dict.fromkeys(c.category for c in getattr(answer, "candidates", ())))
        except (ReasonError, QueryError) as exc:
            error = str(exc)
        seconds = time.perf_counter() - start
        right = bool(labels) and all(label in row.acceptable for label in labels)
        top3 = right or any(c in row.acceptable for c in ranked[:3])
        out.append(Outcome(row, labels, ranked, right, top3, error, seconds))
    return out


def baseline(rows: Sequence[Placement], graphs: ref.ScanGraphs) -> list[Outcome]:
    """The naive baseline: every object of the label nearest to the instruction by cosine."""
    from causalsplat.reason.embed import load_embedder

    embedder = load_embedder()
    out = []
    for row in rows:
        ctx = graphs.context(row.scan)
        start = time.perf_counter()
        labels = list(ctx.categories)
        sims = embedder.similarities(row.text, labels)
        order = sorted(range(len(labels)), key=lambda i: (-sims[i], labels[i]))
        ranked = tuple(labels[i] for i in order)
        chosen = ranked[0]
        answer = tuple(e.category for e in ctx.graph.entities if e.category == chosen)
        right = all(label in row.acceptable for label in answer)
        top3 = any(c in row.acceptable for c in ranked[:3])
        out.append(Outcome(row, answer, ranked, right, top3, None,
                           time.perf_counter() - start))  # fmt: skip
    return out


def summary(outcomes: Sequence[Outcome]) -> dict[str, Any]:
    n = len(outcomes)
    if not n:
        return {"n": 0}
    return {
        "n": n,
        "right": sum(o.right for o in outcomes),
        "accuracy": sum(o.right for o in outcomes) / n,
        "top3": sum(o.top3 for o in outcomes) / n,
        "empty": sum(o.empty for o in outcomes) / n,
        "errors": sum(o.error is not None for o in outcomes) / n,
        "ms": 1000 * sum(o.seconds for o in outcomes) / n,
    }


def main(argv: Sequence[str]) -> int:  # pragma: no cover - a development tool
    import tempfile

    from causalsplat.reason.offline import OfflineReasoner

    split = argv[0] if argv else "train"
    if split not in SPLITS:
        print(f"split must be one of {', '.join(SPLITS)}", file=sys.stderr)
        return 2
    numbers = [a for a in argv[1:] if a.isdigit()]
    limit = int(numbers[0]) if numbers else None
    rows, total = placements(split)
    rows = rows[:limit] if limit else rows
    verbose = "-v" in argv
    with tempfile.TemporaryDirectory() as tmp:
        graphs = ref.ScanGraphs(f"sqlite:///{Path(tmp) / 'ddn.db'}")
        print(f"{split}: {len(rows)} placed of {total}")
        base = baseline(rows, graphs)
        print("baseline", summary(base))
        for name, reasoner in (("offline+embeddings", OfflineReasoner(embeddings=True)),):
            outs = evaluate(rows, reasoner, graphs)
            print(name, summary(outs))
            if verbose:
                for o in outs:
                    if not o.right:
                        print(f"  x {o.placement.text!r} -> {o.labels[:3]} {o.ranked[:4]} "
                              f"want {sorted(o.placement.acceptable)} {o.error or ''}")  # fmt: skip
        graphs.close()
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main(sys.argv[1:]))
