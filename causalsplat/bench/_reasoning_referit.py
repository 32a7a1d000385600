"""ReferIt3D / ScanRefer evaluation with ground-truth objects (the ReferIt3D setting).

Reads ``../shared/data/referit3d_scannet_objects`` (see its ``SOURCE.md``; never copied
into the repository). For each scan an objects document is made from its object table
(id = ScanNet object id, label, AABB centre and size; no points) and ingested into a
store exactly as ``causalsplat ingest-objects`` does, so the graph has our edges. Each
utterance is asked with the reasoner; ReferIt3D counts it correct when the answer is the
target object alone, ScanRefer scores the box IoU of the answer against the target's box.

Row groups: Sr3D by ``reference_type`` (allocentric rows: ``left``, ``right``, ``front``,
``back``), Nr3D easy (at most one distractor of the target's class) / hard and view
dependent / independent (ReferIt3D's word list), ScanRefer by ``unique`` / ``multiple``
(whether the target's class is unique in the scan).
"""

from __future__ import annotations

import ast
import csv
import json
import math
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from causalsplat.eval.reasoning import box_iou, referit_correct
from causalsplat.graph import EdgeConfig
from causalsplat.reason.context import SceneContext
from causalsplat.reason.errors import ReasonError
from causalsplat.reason.reasoner import Reasoner
from queries.errors import QueryError

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "referit3d_scannet_objects"
ALLOCENTRIC = ("left", "right", "front", "back")
#: ReferIt3D's view-dependent words (an utterance using one is view dependent).
VIEW_DEPENDENT_WORDS = frozenset({"facing", "looking", "front", "behind", "back", "right",
                                  "left", "leftmost", "rightmost", "across"})  # fmt: skip


@dataclass(frozen=True, slots=True)
class Row:
    """One utterance with its target object (ScanNet object id) and its groups."""

    dataset: str
    scan: str
    text: str
    target: int
    groups: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class RowOutcome:
    row: Row
    predicted: tuple[int, ...]
    correct: bool
    box_iou: float
    error: str | None
    seconds: float


def objects_document(scan: str, root: Path = DATA, *, colour: bool = True) -> dict[str, Any]:
    """The objects document (DESIGN §9) of one scan's object table; ``colour``: with each
    object's mean colour (the table's ``avg_rgba``) as ``rgb``. Objects with an annotated
    front (``has_front``) face from their box centre towards their ``front_point``."""
    path = root / "objects_info" / f"objects_info_{scan}.json"
    table = json.loads(path.read_text(encoding="utf-8"))
    objects = []
    for o in table:
        lo, hi = o["extension"][:3], o["extension"][3:]
        obj: dict[str, Any] = {
            "id": int(o["id"]),
            "label": str(o["label"]),
            "center": [(a + b) / 2 for a, b in zip(lo, hi, strict=True)],
            "size": [b - a for a, b in zip(lo, hi, strict=True)],
        }
        front = o.get("front_point")
        if o.get("has_front") and isinstance(front, list) and len(front) == 3:
            facing = [f - c for f, c in zip(front, obj["center"], strict=True)]
            if math.hypot(facing[0], facing[1]) > 0.0:
                obj["facing"] = facing
        rgba = o.get("avg_rgba")
        if colour and isinstance(rgba, list) and len(rgba) >= 3:
            obj["rgb"] = [float(v) for v in rgba[:3]]
        objects.append(obj)
    return {"scene_id": scan, "units": "m", "up": "z", "objects": objects}


class ScanGraphs:
    """Scans ingested into one store (built on first use), as reasoner contexts."""

    def __init__(
        self, url: str, root: Path = DATA, edges: EdgeConfig | None = None, *, colour: bool = True
    ) -> None:
        from causalsplat.api import open_store

        self.store = open_store(url)
        self.root = root
        self.edges = edges
        self.colour = colour
        self._contexts: dict[str, SceneContext] = {}
        self.ingest_s = 0.0

    def context(self, scan: str) -> SceneContext:
        ctx = self._contexts.get(scan)
        if ctx is None:
            from causalsplat.objects import objects_to_scene_graph, parse_objects

            start = time.perf_counter()
            doc = objects_document(scan, self.root, colour=self.colour)
            graph = objects_to_scene_graph(parse_objects(doc, source=scan), config=self.edges)
            self.store.save_scene(graph, if_exists="replace")
            self.ingest_s += time.perf_counter() - start
            ctx = self._contexts[scan] = SceneContext(self.store.graph_store.load_scene(scan))
        return ctx

    def close(self) -> None:
        self.store.close()


def _csv(path: Path) -> list[dict[str, str]]:
    with path.open(encoding="utf-8", newline="") as handle:
        return list(csv.DictReader(handle))


def sr3d_rows(split: str, kinds: Sequence[str], root: Path = DATA) -> list[Row]:
    """Rows of ``sr3d_<split>_<kind>.csv`` (kinds: support, vertical, horizontal, between,
    allocentric), grouped by reference type."""
    rows = []
    for kind in kinds:
        path = root / "referit3d" / f"sr3d_{split}_{kind}.csv"
        if not path.exists():
            continue
        for r in _csv(path):
            ref = r["reference_type"]
            group = "allocentric" if ref in ALLOCENTRIC else "egocentric"
            rows.append(Row("sr3d", r["scan_id"], r["utterance"], int(r["target_id"]),
                            (ref, group)))  # fmt: skip
    return rows


def nr3d_rows(name: str, root: Path = DATA) -> list[Row]:
    """Rows of ``nr3d_<name>.csv``: easy/hard from the stimulus id (hard: more than two
    objects of the target's class), view-dependent from ReferIt3D's word list."""
    rows = []
    for r in _csv(root / "referit3d" / f"nr3d_{name}.csv"):
        n_same = int(r["stimulus_id"].split("-")[2])
        tokens = ast.literal_eval(r["tokens"]) if r.get("tokens") else r["utterance"].split()
        view = "view-dependent" if VIEW_DEPENDENT_WORDS & set(tokens) else "view-independent"
        groups = ("hard" if n_same > 2 else "easy", view)
        rows.append(Row("nr3d", r["scan_id"], r["utterance"], int(r["target_id"]), groups))
    return rows


def scanrefer_rows(name: str, root: Path = DATA) -> list[Row]:
    """ScanRefer descriptions of ``ScanRefer_filtered_<name>.json``; unique/multiple from
    the scan's object table."""
    records = json.loads((root / "scanrefer" / f"ScanRefer_filtered_{name}.json").read_text())
    labels: dict[str, dict[int, str]] = {}
    rows = []
    for rec in records:
        scan = rec["scene_id"]
        if scan not in labels:
            table = json.loads((root / "objects_info" / f"objects_info_{scan}.json").read_text())
            labels[scan] = {int(o["id"]): o["label"] for o in table}
        target = int(rec["object_id"])
        same = sum(1 for lab in labels[scan].values() if lab == labels[scan].get(target))
        rows.append(Row("scanrefer", scan, rec["description"], target,
                        ("unique" if same == 1 else "multiple",)))  # fmt: skip
    return rows


def evaluate_rows(rows: Iterable[Row], reasoner: Reasoner, graphs: ScanGraphs) -> list[RowOutcome]:
    """Ask every row; errors count as wrong answers."""
    out = []
    for row in rows:
        ctx = graphs.context(row.scan)
        start = time.perf_counter()
        try:
            answer = reasoner.answer(row.text, ctx)
            predicted, error = answer.entity_ids, None
        except (ReasonError, QueryError) as exc:
            predicted, error = (), str(exc)
        seconds = time.perf_counter() - start
        iou = 0.0
        if len(predicted) == 1 and row.target in ctx.by_id:
            p, t = ctx.by_id[predicted[0]], ctx.by_id[row.target]
            iou = box_iou(p.bbox_min, p.bbox_max, t.bbox_min, t.bbox_max)
        out.append(RowOutcome(row, tuple(predicted), referit_correct(predicted, row.target), iou,
                              error, seconds))  # fmt: skip
    return out


def accuracy(outcomes: Sequence[RowOutcome], group: str | None = None) -> tuple[int, float]:
    """(n, accuracy) over the outcomes of one group (all when ``None``)."""
    chosen = [o for o in outcomes if group is None or group in o.row.groups]
    if not chosen:
        return 0, 0.0
    return len(chosen), sum(o.correct for o in chosen) / len(chosen)


def acc_at(outcomes: Sequence[RowOutcome], k: float, group: str | None = None) -> float:
    chosen = [o for o in outcomes if group is None or group in o.row.groups]
    return sum(o.box_iou >= k for o in chosen) / len(chosen) if chosen else 0.0


def first_label_baseline(
    rows: Iterable[Row], graphs: ScanGraphs, reasoner: Any
) -> list[RowOutcome]:
    """The naive baseline: every object of the first scene label the description names
    (by the reasoner's own category index), whatever else it says."""
    from causalsplat.reason._mentions import mention_at
    from causalsplat.reason._text import tokenize

    out = []
    for row in rows:
        ctx = graphs.context(row.scan)
        start = time.perf_counter()
        tokens = tokenize(row.text)
        index = reasoner.index(ctx)
        categories: tuple[str, ...] = ()
        for i in range(len(tokens)):
            m = mention_at(index, tokens, i)
            if m is not None and m.categories:
                categories = m.categories
                break
        predicted = tuple(sorted(e.id for e in ctx.graph.entities if e.category in categories))
        out.append(RowOutcome(row, predicted, referit_correct(predicted, row.target), 0.0, None,
                              time.perf_counter() - start))  # fmt: skip
    return out


#: A colour word and one the same object cannot also be called (opposite lightness or hue).
OPPOSITE_COLOURS = {
    "white": "black", "black": "white", "brown": "blue", "blue": "brown", "gray": "red",
    "grey": "red", "red": "green", "green": "red", "beige": "blue", "tan": "blue",
    "yellow": "purple", "purple": "yellow", "orange": "blue", "pink": "green",
    "silver": "brown", "teal": "red",
}  # fmt: skip


def contradicted_rows(rows: Iterable[Row], graphs: ScanGraphs) -> list[tuple[Row, Row]]:
    """(original, contradicted) pairs: a description's first colour word replaced by its
    :data:`OPPOSITE_COLOURS` entry, kept only where no object of the target's label in
    the scan is nearest to the new colour term (so that nothing there fits the variant)."""
    import re

    from causalsplat.colors import hex_to_rgb, names_of

    out = []
    for row in rows:
        words = re.findall(r"[a-z]+", row.text.lower())
        word = next((w for w in words if w in OPPOSITE_COLOURS), None)
        if word is None:
            continue
        new = OPPOSITE_COLOURS[word]
        ctx = graphs.context(row.scan)
        label = ctx.by_id[row.target].category if row.target in ctx.by_id else None
        same = [e for e in ctx.graph.entities if e.category == label]
        term = "gray" if new == "grey" else new
        fits = False
        for e in same:
            rgb = next((hex_to_rgb(a.value) for a in e.attributes if a.key == "rgb"), None)
            if rgb is not None and names_of(rgb)[0] == term:
                fits = True
        if fits or not same:
            continue
        text = re.sub(rf"\b{word}\b", new, row.text, count=1, flags=re.IGNORECASE)
        out.append((row, Row(row.dataset, row.scan, text, row.target, row.groups)))
    return out


#: Phenomena of referring language, each recognised by its words (a description may show
#: several): the breakdown ``causalsplat bench --only reasoning`` reports on the dev sets.
PHENOMENA: dict[str, frozenset[str]] = {
    "left / right": frozenset({"left", "right", "leftmost", "rightmost"}),
    "viewpoint": frozenset({"facing", "face", "looking", "entering", "enter", "standing",
                            "sitting", "walk", "walking"}),
    "closest / farthest": frozenset({"closest", "nearest", "farthest", "furthest", "closer",
                                     "farther", "further"}),
    "middle": frozenset({"middle", "center", "centre"}),
    "ordinal": frozenset({"first", "second", "third", "fourth", "fifth", "2nd", "3rd", "4th",
                          "last"}),
    "negation / exclusion": frozenset({"not", "no", "without", "other", "except", "isn",
                                       "nor"}),
    "between": frozenset({"between"}),
    "size": frozenset({"small", "smaller", "smallest", "large", "larger", "largest", "big",
                       "bigger", "biggest", "tall", "taller", "tallest", "short", "shorter",
                       "shortest", "long", "longer", "wide", "wider", "narrow"}),
    "arrangement": frozenset({"row", "group", "cluster", "pair", "line", "set", "stack"}),
}  # fmt: skip


def phenomena(text: str) -> tuple[str, ...]:
    """The :data:`PHENOMENA` a description shows, and ``colour`` when it names a colour."""
    import re

    from causalsplat.colors import is_color_word

    words = set(re.findall(r"[a-z0-9]+", text.lower()))
    found = [name for name, cues in PHENOMENA.items() if cues & words]
    if any(is_color_word(w) for w in words):
        found.insert(0, "colour")
    return tuple(found)


def main(argv: Sequence[str]) -> int:  # pragma: no cover - a development tool
    """``python -m causalsplat.bench._reasoning_referit nr3d|scanrefer [NAME]``: the
    offline reasoner on one set of rows (default the 1,000-row *train* samples the
    reasoner is developed on), with ``--none`` the contradicted-colour variants
    (ScanRefer), with ``--jsonl FILE`` each row's answer and reading, to compare two trees
    row by row."""
    import argparse
    import tempfile

    from causalsplat.reason.offline import OfflineReasoner

    parser = argparse.ArgumentParser(prog="python -m causalsplat.bench._reasoning_referit")
    parser.add_argument("dataset", choices=("nr3d", "scanrefer"))
    parser.add_argument("name", nargs="?", default="train_sampled1000",
                        help="nr3d_<name>.csv or ScanRefer_filtered_<name>.json")  # fmt: skip
    parser.add_argument("--none", action="store_true", help="also the contradicted variants")
    parser.add_argument("--jsonl", metavar="FILE", help="write every row's answer here")
    args = parser.parse_args(argv)
    try:
        rows = nr3d_rows(args.name) if args.dataset == "nr3d" else scanrefer_rows(args.name)
    except FileNotFoundError as exc:
        parser.error(f"no such rows file: {exc.filename}")
    with tempfile.TemporaryDirectory() as tmp:
        graphs = ScanGraphs(f"sqlite:///{Path(tmp) / 'rows.db'}")
        reasoner = OfflineReasoner()
        outcomes = evaluate_rows(rows, reasoner, graphs)
        right = sum(o.correct for o in outcomes)
        print(f"{args.dataset} {args.name}: {right} of {len(outcomes)} right, "
              f"{sum(not o.predicted for o in outcomes)} answered with nothing")  # fmt: skip
        if args.none:
            pairs = contradicted_rows(rows, graphs)
            originals = evaluate_rows([p[0] for p in pairs], reasoner, graphs)
            variants = evaluate_rows([p[1] for p in pairs], reasoner, graphs)
            print(f"contradicted variants: {sum(not o.predicted for o in variants)} of "
                  f"{len(pairs)} rightly answered with nothing, originals "
                  f"{sum(not o.predicted for o in originals)} wrongly")  # fmt: skip
        if args.jsonl:
            with open(args.jsonl, "w", encoding="utf-8") as out:
                for o in outcomes:
                    record = {"scan": o.row.scan, "text": o.row.text, "target": o.row.target,
                              "predicted": list(o.predicted), "correct": o.correct,
                              "error": o.error}  # fmt: skip
                    out.write(json.dumps(record) + "\n")
        graphs.close()
    return 0


if __name__ == "__main__":  # pragma: no cover
    import sys

    raise SystemExit(main(sys.argv[1:]))
