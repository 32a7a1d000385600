"""Queries from the Sr3D, Nr3D and ScanRefer utterances that carry a target object id.

Every utterance becomes one ``spatial`` query of the DESIGN §9 queries file whose target is
the utterance's object id (ScanNet v2 objectId = the external id in ``objects.json``).
Query ids say where each came from: ``sr3d-<reference type>-NNN`` (``between``, ``left``,
``supported-by``...), ``nr3d-NNN`` and ``scanrefer-NNN``. Exact duplicates (same text and
target) are kept once; targets that are not in the object table are refused.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from causalsplat.scannet.source import ScanNetFormatError, ScanNetSource, read_csv_rows


@dataclass(frozen=True, slots=True)
class Utterance:
    """One query: ``id``, ``text``, ``type`` (always ``spatial``) and its target ids."""

    id: str
    text: str
    type: str
    targets: tuple[int, ...]


def _target(raw: str, path: Path, n_objects: int) -> int:
    try:
        value = int(str(raw).strip())
    except ValueError:
        raise ScanNetFormatError(f"{path}: target id {raw!r} is not an integer") from None
    if not 0 <= value < n_objects:
        raise ScanNetFormatError(f"{path}: target id {value} is not in the object table")
    return value


def load_utterances(source: ScanNetSource) -> tuple[Utterance, ...]:
    """The Sr3D, Nr3D and ScanRefer queries of ``source`` (module docstring)."""
    lang = source.root / "language_gt"
    scan, n = source.scan_id, len(source.objects)
    out: list[Utterance] = []
    seen: set[tuple[str, int]] = set()

    def add(prefix: str, text: str, target: int) -> None:
        text = " ".join(text.split())
        if not text or (text, target) in seen:
            return
        seen.add((text, target))
        count = sum(1 for u in out if u.id.startswith(prefix + "-"))
        out.append(Utterance(f"{prefix}-{count:03d}", text, "spatial", (target,)))

    sr3d = lang / f"sr3d_{scan}.csv"
    for row in read_csv_rows(sr3d):
        kind = (row.get("reference_type") or "unknown").strip().replace(" ", "-")
        add(f"sr3d-{kind}", row.get("utterance", ""), _target(row.get("target_id", ""), sr3d, n))
    nr3d = lang / f"nr3d_{scan}.csv"
    for row in read_csv_rows(nr3d):
        add("nr3d", row.get("utterance", ""), _target(row.get("target_id", ""), nr3d, n))
    scanrefer = lang / f"scanrefer_{scan}.json"
    try:
        records = json.loads(scanrefer.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise
    except json.JSONDecodeError as exc:
        raise ScanNetFormatError(f"{scanrefer}: not valid JSON ({exc})") from exc
    for rec in records:
        add(
            "scanrefer",
            str(rec.get("description", "")),
            _target(rec.get("object_id", ""), scanrefer, n),
        )
    return tuple(out)
