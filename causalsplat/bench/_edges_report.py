"""Markdown of the edge benchmark (:mod:`causalsplat.bench.edges`)."""

from __future__ import annotations

from typing import Any

_TYPES = ("supported-by", "supporting", "above", "below")


def _pct(hold: int, total: int) -> str:
    return f"{hold:,}/{total:,} ({100.0 * hold / total:.1f}%)" if total else "-"


def _timing(rows: list[dict[str, Any]]) -> str:
    lines = [
        "| entities | relations | candidate pairs (of all) | KD-tree s (pairs + rules only)"
        " | all pairs, vectorised s | reference loop s | reference / KD | all pairs / KD"
        " | relations that differ |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        share = 100.0 * r["candidates"] / r["pairs"] if r["pairs"] else 0.0
        lines.append(
            f"| {r['entities']:,} | {r['relations']:,} | {r['candidates']:,} ({share:.2f}%)"
            f" | {r['kdtree_s']:.3f} ({r['kdtree_rules_s']:.3f})"
            f" | {r['all_pairs_s']:.3f} | {r['reference_s']:.2f}"
            f" | {r['reference_s'] / r['kdtree_s']:.1f}x | {r['all_pairs_s'] / r['kdtree_s']:.1f}x"
            f" | {r['differ_reference']} / {r['differ_all_pairs']} |"
        )
    return "\n".join(lines)


def _split_table(v: dict[str, Any], unit: str) -> list[str]:
    """One line per config and split: ``unit`` is ``relations`` or ``rows``."""
    lines = [
        "| config | split | " + " | ".join(_TYPES) + " | all support+vertical |",
        "|---|---|" + "---:|" * (len(_TYPES) + 1),
    ]
    for c in v["configs"]:
        for split in ("train", "test"):
            cells, hold, total = [], 0, 0
            for t in _TYPES:
                g = c["vertical"].get(f"{split}/{t}", {})
                cells.append(_pct(g.get(f"{unit}_hold", 0), g.get(unit, 0)))
                hold, total = hold + g.get(f"{unit}_hold", 0), total + g.get(unit, 0)
            lines.append(f"| {c['label']} | {split} | {' | '.join(cells)} | {_pct(hold, total)} |")
    return lines


def _validation(v: dict[str, Any]) -> str:
    parts = [f"Scans: {v['scans']:,}. Distinct (scan, target, anchor, type) relations, then rows"
             " (utterances), for which the stated edge is in our graph:\n"]  # fmt: skip
    parts += _split_table(v, "relations")
    parts += ["", "Per row (utterance):", "", *_split_table(v, "rows")]
    parts += ["", "Horizontal rows (Sr3D test; the train file is absent): the target is the"
              " closest/farthest object of its label to the anchor by centroid distance:", "",
              "| type | relations | rows |", "|---|---:|---:|"]  # fmt: skip
    for key, g in sorted(v["horizontal"].items()):
        parts.append(
            f"| {key.split('/')[1]} | {_pct(g['relations_hold'], g['relations'])}"
            f" | {_pct(g['rows_hold'], g['rows'])} |"
        )
    parts += ["", "Against Sr3D's box criteria over all ordered object pairs of these scans"
              " (precision = ours that Sr3D's geometry also gives; recall = the converse):", "",
              "| config | edge | ours | Sr3D geometry | both | precision | recall |",
              "|---|---|---:|---:|---:|---:|---:|"]  # fmt: skip
    for c in v["configs"]:
        for edge, g in sorted(c["geometry"].items()):
            parts.append(
                f"| {c['label']} | {edge} | {g['ours']:,} | {g['sr3d']:,} | {g['both']:,}"
                f" | {_pct(g['both'], g['ours'])} | {_pct(g['both'], g['sr3d'])} |"
            )
    parts += ["", "| config | entities / scan | edges / scan by type | build ms / scan"
              " (mean, median, max) |", "|---|---:|---|---|"]  # fmt: skip
    for c in v["configs"]:
        per = ", ".join(f"{k} {n:.1f}" for k, n in c["edges_per_scan"].items())
        parts.append(
            f"| {c['label']} | {c['entities_per_scan']:.1f} | {per} | {1e3 * c['mean_s']:.1f},"
            f" {1e3 * c['median_s']:.1f}, {1e3 * c['max_s']:.1f} |"
        )
    return "\n".join(parts)


def markdown(timing: list[dict[str, Any]], validation: dict[str, Any] | None) -> str:
    text = [
        "Random multi-room scenes (6 m rooms with floor, walls, furniture and objects resting"
        " on or inside furniture; seed 0). KD-tree: `build_relations` (candidate pairs from"
        " KD-trees, vectorised rules). Baselines in the same run: the reference loop"
        " `build_relations_bruteforce` (scalar Python over every pair) and the same"
        ' vectorised rules on every pair (`candidates="all"`). KD-tree time is the best of'
        ' 3 runs up to 1k entities, one run above; the baselines run once. "Relations that'
        ' differ": reference / all pairs, against the KD-tree output (relations and'
        " evidence compared exactly).",
        "",
        _timing(timing),
        "",
        "In brackets: the KD-tree path up to the rule results (trees, candidate pairs,"
        " vectorised rules, one run); the rest of its time is spent creating and validating"
        " the `Relation` objects, which all three paths do alike.",
    ]
    if validation is None:
        text += ["", "Sr3D validation skipped: `../shared/data/referit3d_scannet_objects` absent."]
    else:
        text += ["", "### Sr3D validation on ScanNet object tables", "", _validation(validation)]
    return "\n".join(text)
