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

The same instructions said as commands (:func:`as_command`: "I want to heat up my lunch"
-> "heat up my lunch") measure how much the wording of a need matters: the instructions
are DDN's, the command form a mechanical rewrite of them.

The naive baseline, run on the same placements: every object of the scene label whose
name is nearest to the instruction by MiniLM cosine.

Run ``python -m causalsplat.bench._reasoning_ddn train`` while developing (train split
only; the validation split is for the report). ``--vlm URL --model NAME`` asks an
OpenAI-compatible server instead (``make vlm-check`` does, on the validation split), with
``--json FILE`` for the report.
"""

from __future__ import annotations

import json
import random
import re
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
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
    fallback: str | None = None

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


#: The want that opens an instruction, taken off to say it as a command.
_WANT_FRAME = re.compile(
    r"^\s*(?:i(?:\s+(?:want|need|would\s+like|wish)|'d\s+like)\s+to|let\s+me)\s+(\S.*?)[\s.!]*$",
    re.IGNORECASE,
)


def as_command(text: str) -> str | None:
    """The instruction said as a command ("I want to heat up my lunch." -> "heat up my
    lunch"), or ``None`` when it does not open with a want ("I am thirsty").

    >>> as_command("I need to dry my hair.")
    'dry my hair'
    >>> as_command("I'm hungry") is None
    True
    """
    m = _WANT_FRAME.match(text)
    return None if m is None else m.group(1)


def command_placements(split: str) -> list[tuple[Placement, Placement]]:
    """(want, command) pairs: each placeable instruction that opens with a want, and the
    same placement said as a command (:func:`as_command`)."""
    rows, _ = placements(split)
    return [(row, replace(row, text=cmd)) for row in rows if (cmd := as_command(row.text))]


def absent_placements(split: str) -> list[Placement]:
    """Each placeable instruction of a split in a scan that holds *no* acceptable object
    (seeded by the text, among scans of :data:`MIN_OTHER_LABELS` or more counted labels):
    the right answer is nothing. The labels map is partial, so a scan may still hold
    something that would do; the rate of empty answers here is a lower bound on how
    often the reasoner says "nothing fits" when nothing does."""
    rows, _ = placements(split)
    scans = scan_labels()
    names = sorted(scans)
    out = []
    for row in rows:
        pool = [
            s
            for s in names
            if not scans[s] & row.acceptable and len(scans[s] - _NOT_COUNTED) >= MIN_OTHER_LABELS
        ]
        if pool:
            scan = random.Random(f"ddn-absent:{row.text}").choice(pool)
            out.append(Placement(row.text, scan, row.acceptable))
    return out


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
        fallback = None
        try:
            answer = reasoner.answer(row.text, ctx)
            labels = answer.categories
            ranked = tuple(dict.fromkeys(c.category for c in getattr(answer, "candidates", ())))
            fallback = answer.fallback
        except (ReasonError, QueryError) as exc:
            error = str(exc)
        seconds = time.perf_counter() - start
        right = bool(labels) and all(label in row.acceptable for label in labels)
        top3 = right or any(c in row.acceptable for c in ranked[:3])
        out.append(Outcome(row, labels, ranked, right, top3, error, seconds, fallback))
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
        "fallbacks": sum(o.fallback is not None for o in outcomes) / n,
        "ms": 1000 * sum(o.seconds for o in outcomes) / n,
    }


def main(argv: Sequence[str]) -> int:  # pragma: no cover - a development tool
    import argparse
    import tempfile

    from causalsplat.reason.offline import OfflineReasoner

    parser = argparse.ArgumentParser(prog="python -m causalsplat.bench._reasoning_ddn")
    parser.add_argument("split", nargs="?", default="train", choices=sorted(SPLITS))
    parser.add_argument("limit", nargs="?", type=int, default=0, help="first N placements")
    parser.add_argument("-v", "--verbose", action="store_true", help="print every miss")
    parser.add_argument("--vlm", metavar="URL", help="an OpenAI-compatible server's /v1 root")
    parser.add_argument("--model", help="the server's model name (with --vlm)")
    parser.add_argument("--max-tokens", type=int, default=None, help="a reply's token budget")
    parser.add_argument("--timeout", type=float, default=600.0, help="seconds per reply")
    parser.add_argument("--record", metavar="FILE", help="keep the exchanges (JSONL)")
    parser.add_argument("--json", metavar="FILE", help="write the report here")
    args = parser.parse_args(argv)
    rows, total = placements(args.split)
    rows = rows[: args.limit] if args.limit else rows
    reasoners: list[tuple[str, Reasoner]] = [("offline", OfflineReasoner())]
    if args.vlm:
        from causalsplat.openai_compat import VLMConfig
        from causalsplat.reason.vlm import VLMReasoner

        config = VLMConfig.from_env(base_url=args.vlm, model=args.model, timeout_s=args.timeout,
                                    max_tokens=args.max_tokens)  # fmt: skip
        reasoners.append(("vlm", VLMReasoner(config=config, record=args.record)))
    report: dict[str, Any] = {"split": args.split, "placed": len(rows), "total": total}
    with tempfile.TemporaryDirectory() as tmp:
        graphs = ref.ScanGraphs(f"sqlite:///{Path(tmp) / 'ddn.db'}")
        print(f"{args.split}: {len(rows)} placed of {total}")
        report["baseline"] = summary(baseline(rows, graphs))
        print("baseline", report["baseline"])
        for name, reasoner in reasoners:
            outs = evaluate(rows, reasoner, graphs)
            report[name] = summary(outs)
            report[name]["fallback_reasons"] = sorted(
                {(o.fallback or "").split(":", 1)[0] for o in outs if o.fallback}
            )
            print(name, report[name])
            for o in outs if args.verbose else ():
                if not o.right:
                    print(f"  x {o.placement.text!r} -> {o.labels[:3]} {o.ranked[:4]} "
                          f"want {sorted(o.placement.acceptable)} {o.error or ''}")  # fmt: skip
        graphs.close()
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main(sys.argv[1:]))
