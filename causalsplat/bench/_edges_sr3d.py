"""Edge validation on real data: ScanNet object tables against Sr3D relation labels.

Reads ``../shared/data/referit3d_scannet_objects`` (object tables of 1,513 scans and the
Sr3D CSVs; see its ``SOURCE.md``): entity id = ScanNet object id, box = ``extension``,
centroid = ``centroid``. For each Sr3D row of a support or vertical type, the relation
the row states must be one of our edges between target and anchor
(``supported-by`` -> target ``supported_by`` anchor, ``supporting`` -> ``supports``,
``above``, ``below``). For horizontal rows, the target must be the closest (farthest)
object of its label to the anchor by centroid distance. Rows repeat a relation with
several utterances: results are given per distinct ``(scan, target, anchor, type)``
and per row.
"""

from __future__ import annotations

import ast
import csv
import json
import math
import time
from collections import Counter, defaultdict
from dataclasses import dataclass
from pathlib import Path

from causalsplat.graph import EdgeConfig, build_relations
from graph_store import Entity

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "referit3d_scannet_objects"
EDGE_OF = {
    "supported-by": "supported_by",
    "supporting": "supports",
    "above": "above",
    "below": "below",
}
SPLITS = ("train", "test")


@dataclass(frozen=True, slots=True)
class Sr3dRow:
    """One Sr3D referral: ``target`` is ``reference_type`` relative to ``anchor``."""

    split: str
    scan: str
    target: int
    anchor: int
    reference_type: str

    @property
    def key(self) -> tuple[str, int, int, str]:
        return (self.scan, self.target, self.anchor, self.reference_type)


def scan_entities(scan: str, root: Path = DATA) -> tuple[Entity, ...]:
    """The object table of one scan as entities (id = ScanNet object id)."""
    path = root / "objects_info" / f"objects_info_{scan}.json"
    table = json.loads(path.read_text(encoding="utf-8"))
    return tuple(
        Entity(
            id=int(o["id"]),
            category=str(o["label"]),
            centroid=tuple(o["centroid"]),
            bbox_min=tuple(o["extension"][:3]),
            bbox_max=tuple(o["extension"][3:]),
            external_id=str(o["id"]),
        )
        for o in table
    )


def all_scans(root: Path = DATA) -> list[str]:
    return sorted(p.stem.removeprefix("objects_info_") for p in (root / "objects_info").iterdir())


def read_rows(split: str, kinds: tuple[str, ...], root: Path = DATA) -> list[Sr3dRow]:
    """Rows of ``sr3d_<split>_<kind>.csv`` for each kind (``support``, ``vertical``...)."""
    rows = []
    for kind in kinds:
        path = root / "referit3d" / f"sr3d_{split}_{kind}.csv"
        if not path.exists():
            continue
        with path.open(encoding="utf-8", newline="") as handle:
            for r in csv.DictReader(handle):
                anchors = ast.literal_eval(r["anchor_ids"])
                rows.append(
                    Sr3dRow(split, r["scan_id"], int(r["target_id"]), int(anchors[0]),
                            r["reference_type"])
                )  # fmt: skip
    return rows


@dataclass(frozen=True, slots=True)
class ScanEdges:
    """The edges of one scan as ``{(src, type, dst)}`` and the time building them took."""

    entities: tuple[Entity, ...]
    edges: frozenset[tuple[int, str, int]]
    build_s: float


def build_scans(scans: list[str], config: EdgeConfig) -> dict[str, ScanEdges]:
    out = {}
    for scan in scans:
        entities = scan_entities(scan)
        start = time.perf_counter()
        relations = build_relations(entities, config)
        elapsed = time.perf_counter() - start
        edges = frozenset((r.src, r.type.value, r.dst) for r in relations)
        out[scan] = ScanEdges(entities, edges, elapsed)
    return out


def score_vertical(rows: list[Sr3dRow], built: dict[str, ScanEdges]) -> dict[str, dict[str, int]]:
    """Per split and reference type: distinct relations and rows, and how many hold."""
    counts: dict[str, Counter[str]] = defaultdict(Counter)
    seen: set[tuple[str, int, int, str]] = set()
    for row in rows:
        if row.scan not in built:
            continue
        holds = (row.target, EDGE_OF[row.reference_type], row.anchor) in built[row.scan].edges
        group = counts[f"{row.split}/{row.reference_type}"]
        group["rows"] += 1
        group["rows_hold"] += holds
        if row.key not in seen:
            seen.add(row.key)
            group["relations"] += 1
            group["relations_hold"] += holds
    return {k: dict(v) for k, v in counts.items()}


def score_horizontal(rows: list[Sr3dRow], built: dict[str, ScanEdges]) -> dict[str, dict[str, int]]:
    """Closest/farthest rows: is the target the closest/farthest of its label?"""
    counts: dict[str, Counter[str]] = defaultdict(Counter)
    seen: set[tuple[str, int, int, str]] = set()
    for row in rows:
        if row.scan not in built:
            continue
        by_id = {e.id: e for e in built[row.scan].entities}
        target, anchor = by_id[row.target], by_id[row.anchor]
        same = [e for e in by_id.values() if e.category == target.category]
        distance = {e.id: math.dist(e.centroid, anchor.centroid) for e in same}
        pick = min if row.reference_type == "closest" else max
        holds = pick(distance, key=lambda k: (distance[k], k)) == row.target
        group = counts[f"{row.split}/{row.reference_type}"]
        group["rows"] += 1
        group["rows_hold"] += holds
        if row.key not in seen:
            seen.add(row.key)
            group["relations"] += 1
            group["relations_hold"] += holds
    return {k: dict(v) for k, v in counts.items()}


def geometry_agreement(built: dict[str, ScanEdges]) -> dict[str, dict[str, int]]:
    """Our object-object edges against Sr3D's published box criteria, over all pairs.

    Sr3D's generator (its ``hp.yml``): supported-by when ``|bottom_t - top_a| <= 0.15 m``,
    the top-view intersection covers more than 0.3 of the target's footprint and the
    target's footprint is less than 1.5x the anchor's; above when ``bottom_t - top_a >
    0.06 m`` and the intersection covers more than 0.2 of either footprint. Our
    ``above`` is compared with "Sr3D above or supported-by" (a thing resting on another
    is above it by the centroid rule). Category lists and structural entities are left
    out. Counts: ours, Sr3D's, both.
    """
    counts: dict[str, Counter[str]] = defaultdict(Counter)
    for scan in built.values():
        objects = [e for e in scan.entities if e.category not in ("floor", "wall", "ceiling")]
        for t in objects:
            for a in objects:
                if t.id == a.id:
                    continue
                support, above = _sr3d_geometry(t, a)
                for name, theirs in (("supported_by", support), ("above", above or support)):
                    ours = (t.id, name, a.id) in scan.edges
                    group = counts[name]
                    group["ours"] += ours
                    group["sr3d"] += theirs
                    group["both"] += ours and theirs
    return {k: dict(v) for k, v in counts.items()}


def _sr3d_geometry(t: Entity, a: Entity) -> tuple[bool, bool]:
    ix = min(t.bbox_max[0], a.bbox_max[0]) - max(t.bbox_min[0], a.bbox_min[0])
    iy = min(t.bbox_max[1], a.bbox_max[1]) - max(t.bbox_min[1], a.bbox_min[1])
    inter = max(ix, 0.0) * max(iy, 0.0)
    area_t = t.size[0] * t.size[1]
    area_a = a.size[0] * a.size[1]
    if area_t <= 0 or area_a <= 0:
        return False, False
    gap = t.bbox_min[2] - a.bbox_max[2]
    support = abs(gap) <= 0.15 and inter / area_t > 0.3 and area_t / area_a < 1.5
    above = gap > 0.06 and max(inter / area_t, inter / area_a) > 0.2
    return support, above
