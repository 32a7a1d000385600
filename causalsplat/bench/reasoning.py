"""Reasoning benchmark: the offline reasoner on real language and on synthetic scenes.

* DDN demand instructions (written by others) placed in real ScanNet object tables
  (:mod:`causalsplat.bench._reasoning_ddn`): the validation split, all of it, for the
  offline reasoner with and without sentence embeddings and the naive baseline (nearest
  scene label by MiniLM cosine) in the same run; development used the train split only.
* Every reasoning level on scene0000_00 (GT objects), instructions and answers printed.
* ReferIt3D setting (ground-truth objects of each scan ingested with our edges, see
  :mod:`causalsplat.bench._reasoning_referit`): Sr3D *test* rows by reference type,
  Nr3D *test* (easy/hard, view-dependent/independent), ScanRefer sampled *val* Acc@0.25 /
  Acc@0.5. Development used the train files only.
* Synthetic benchmark scenes (generated, GT entities ingested, GT per-Gaussian labels
  stored): accuracy and 3D mIoU on Gaussians per reasoning level, lexical and with
  sentence embeddings.
* Run time (:mod:`causalsplat.bench._reasoning_timing`): cold ``causalsplat ask`` against
  ``python -c pass`` and ``import causalsplat.api``; warm ``scene.ask`` at about 100
  entities against running the same program on the reference executor.

``run(quick=True)`` samples a few hundred rows per set and uses one tiny synthetic scene.
"""

from __future__ import annotations

import json
import random
import tempfile
import time
from pathlib import Path
from typing import Any

from causalsplat.bench import BenchReport
from causalsplat.bench import _reasoning_ddn as ddn
from causalsplat.bench import _reasoning_referit as ref
from causalsplat.bench._reasoning_timing import cold_ask, persist_scan, warm_ask

NAME = "reasoning"
SR3D_KINDS = ("support", "vertical", "horizontal", "between", "allocentric")
SR3D_TYPES = ("closest", "farthest", "above", "below", "supported-by", "supporting", "between",
              "left", "right", "front", "back")  # fmt: skip
LEVELS = ("spatial", "commonsense", "affordance", "counterfactual", "intrinsic")


def _sample(rows: list[ref.Row], n: int | None) -> list[ref.Row]:
    if n is None or len(rows) <= n:
        return rows
    return random.Random(0).sample(rows, n)


def _pct(x: float) -> str:
    return f"{100 * x:.1f}%"


def _row(*cells: object) -> str:
    return "| " + " | ".join(str(c) for c in cells) + " |"


NAIVE_REFER = "naive: every object of the first label named"


def _phenomena(
    graphs: ref.ScanGraphs, reasoner: Any, quick: bool, data: dict[str, Any]
) -> list[str]:
    """Accuracy by phenomenon of referring language on the *dev* sets (Nr3D and ScanRefer
    train samples: where development looks; the test and val rows above are not split)."""
    limit = 200 if quick else None
    dev = {
        "Nr3D train": _sample(ref.nr3d_rows("train_sampled1000"), limit),
        "ScanRefer train": _sample(ref.scanrefer_rows("train_sampled1000"), limit),
    }
    results = {name: ref.evaluate_rows(rows, reasoner, graphs) for name, rows in dev.items()}
    names = ["colour", *ref.PHENOMENA, "none of these"]
    lines = ["Accuracy by phenomenon on the development sets (a description counts under "
             "every phenomenon its words show; n, accuracy):", "",
             _row("phenomenon", *dev), "|---|" + "---:|" * len(dev)]  # fmt: skip
    for phen in names:
        cells = []
        for name, outs in results.items():
            chosen = [
                o for o in outs
                if (phen in ref.phenomena(o.row.text)
                    or (phen == "none of these" and not ref.phenomena(o.row.text)))
            ]  # fmt: skip
            acc = sum(o.correct for o in chosen) / max(1, len(chosen))
            data[f"phenomena/{name}/{phen}"] = {"n": len(chosen), "accuracy": acc}
            cells.append(f"{len(chosen)}, {_pct(acc)}")
        lines.append(_row(phen, *cells))
    return lines


def _referit(graphs: ref.ScanGraphs, quick: bool, tmp: Path) -> tuple[list[str], dict[str, Any]]:
    from causalsplat.reason.offline import OfflineReasoner

    reasoner = OfflineReasoner()
    limit = 300 if quick else None
    data: dict[str, Any] = {}
    lines = ["### ReferIt3D setting (GT objects, our edges, offline lexical reasoner)", ""]
    sets = {
        "sr3d": _sample(ref.sr3d_rows("test", SR3D_KINDS), limit),
        "nr3d": _sample(ref.nr3d_rows("test"), limit),
        "scanrefer": _sample(ref.scanrefer_rows("val_sampled1000"), 200 if quick else None),
    }
    outcomes = {}
    for name, rows in sets.items():
        start = time.perf_counter()
        outcomes[name] = ref.evaluate_rows(rows, reasoner, graphs)
        data[f"{name}_s"] = time.perf_counter() - start
    sr3d = outcomes["sr3d"]
    # The same rows on graphs whose edges use the tolerance chosen on Sr3D *train* rows
    # (EdgeConfig.tuned_for_scannet, see the edges section); a store of their own.
    from causalsplat.graph import EdgeConfig

    tuned_graphs = ref.ScanGraphs(f"sqlite:///{tmp / 'referit-tuned.db'}",
                                  edges=EdgeConfig.tuned_for_scannet())  # fmt: skip
    tuned = ref.evaluate_rows(sets["sr3d"], reasoner, tuned_graphs)
    tuned_graphs.close()
    lines += ["Sr3D test rows, by reference type (edges: the paper's defaults, and the "
              "horizontal tolerance tuned on Sr3D train rows):", "",
              "| reference type | n | accuracy, paper defaults | accuracy, tuned on train |",
              "|---|---:|---:|---:|"]  # fmt: skip
    for kind in (*SR3D_TYPES, "egocentric", "allocentric", None):
        n, acc = ref.accuracy(sr3d, kind)
        _, acc_tuned = ref.accuracy(tuned, kind)
        label = kind or "**all**"
        lines.append(f"| {label} | {n} | {_pct(acc)} | {_pct(acc_tuned)} |")
        data[f"sr3d/{kind or 'all'}"] = {"n": n, "accuracy": acc, "tuned": acc_tuned}
    nr3d = outcomes["nr3d"]
    lines += ["", "Nr3D test:", "", "| group | n | accuracy |", "|---|---:|---:|"]
    for group in ("easy", "hard", "view-dependent", "view-independent", None):
        n, acc = ref.accuracy(nr3d, group)
        lines.append(f"| {group or '**all**'} | {n} | {_pct(acc)} |")
        data[f"nr3d/{group or 'all'}"] = {"n": n, "accuracy": acc}
    sr = outcomes["scanrefer"]
    lines += ["", "ScanRefer val (sampled 1000), GT boxes:", "",
              "| group | n | Acc@0.25 | Acc@0.5 |", "|---|---:|---:|---:|"]  # fmt: skip
    for group in ("unique", "multiple", None):
        n, _ = ref.accuracy(sr, group)
        a25, a50 = ref.acc_at(sr, 0.25, group), ref.acc_at(sr, 0.5, group)
        lines.append(f"| {group or '**all**'} | {n} | {_pct(a25)} | {_pct(a50)} |")
        data[f"scanrefer/{group or 'all'}"] = {"n": n, "acc25": a25, "acc50": a50}
    # the same rows without colour (the tables' avg_rgba left out), and the naive baseline
    plain = ref.ScanGraphs(f"sqlite:///{tmp / 'referit-plain.db'}", colour=False)
    without = ref.evaluate_rows(sets["scanrefer"], reasoner, plain)
    plain.close()
    naive = ref.first_label_baseline(sets["scanrefer"], graphs, reasoner)
    runs = (("offline, no colour", without), (NAIVE_REFER, naive))
    for name, outs in runs:
        cells = []
        for group in ("unique", "multiple", None):
            cells.append(_pct(ref.acc_at(outs, 0.25, group) if name.startswith("offline")
                              else ref.accuracy(outs, group)[1]))  # fmt: skip
        data[f"scanrefer/{name}"] = cells
    lines += ["", "The same descriptions without the tables' colours, and the naive baseline "
              "(Acc@0.25; the baseline is right only when the label is unique):", "",
              "| run | unique | multiple | all |", "|---|---:|---:|---:|"]  # fmt: skip
    lines += [f"| {name} | {' | '.join(data[f'scanrefer/{name}'])} |" for name, _ in runs]
    naive_sr3d = ref.first_label_baseline(sets["sr3d"], graphs, reasoner)
    naive_nr3d = ref.first_label_baseline(sets["nr3d"], graphs, reasoner)
    data["naive/sr3d"], data["naive/nr3d"] = (ref.accuracy(naive_sr3d)[1],
                                              ref.accuracy(naive_nr3d)[1])  # fmt: skip
    lines += ["", "The same naive baseline on the Sr3D test rows: "
              f"{_pct(data['naive/sr3d'])}; on the Nr3D test rows: {_pct(data['naive/nr3d'])} "
              "(ReferIt3D targets have distractors of their class by design)."]  # fmt: skip
    # "none": each description with a colour word, and the same with the word replaced by
    # one that no object of the target's label is nearest to
    pairs = ref.contradicted_rows(sets["scanrefer"], graphs)
    originals = ref.evaluate_rows([p[0] for p in pairs], reasoner, graphs)
    variants = ref.evaluate_rows([p[1] for p in pairs], reasoner, graphs)
    wrong_none = sum(not o.predicted for o in originals) / max(1, len(originals))
    right_none = sum(not o.predicted for o in variants) / max(1, len(variants))
    data["scanrefer/none"] = {"n": len(pairs), "right_none": right_none,
                              "wrong_none": wrong_none}  # fmt: skip
    lines += ["", f"\"None\": {len(pairs)} of these descriptions name a colour; with it "
              "replaced by its opposite (white/black, brown/blue...) where no object of the "
              f"target's label is nearest to the new colour, {_pct(right_none)} are rightly "
              f"answered with nothing; the originals are wrongly answered with nothing in "
              f"{_pct(wrong_none)}. (Colours are the tables' mean vertex colours, darkened "
              "and desaturated by the scans' lighting.)"]  # fmt: skip
    lines += ["", *_phenomena(graphs, reasoner, quick, data)]
    per_row = [o.seconds for rows in outcomes.values() for o in rows]
    data["ms_per_utterance"] = 1000 * sum(per_row) / max(1, len(per_row))
    lines += ["", f"Mean reasoning time {data['ms_per_utterance']:.1f} ms per utterance over "
              f"{len(per_row)} utterances; {len(graphs._contexts)} scans ingested in "
              f"{graphs.ingest_s:.1f} s."]  # fmt: skip
    return lines, data


def _ddn(graphs: ref.ScanGraphs, quick: bool) -> tuple[list[str], dict[str, Any]]:
    from causalsplat.reason.embed import embeddings_available
    from causalsplat.reason.offline import OfflineReasoner

    rows, total = ddn.placements("val")
    if quick:
        rows = rows[:60]
    runs: dict[str, list[ddn.Outcome]] = {}
    seconds: dict[str, float] = {}
    configs: list[tuple[str, Any]] = [("offline, lexical only", OfflineReasoner(embeddings=False))]
    if embeddings_available():
        configs.append(("offline, embeddings, no need adapter",
                        OfflineReasoner(embeddings=True, adapter=False)))  # fmt: skip
        configs.append(("offline, embeddings + need adapter (default)",
                        OfflineReasoner(embeddings=True)))  # fmt: skip
    for name, reasoner in configs:
        start = time.perf_counter()
        runs[name] = ddn.evaluate(rows, reasoner, graphs)
        seconds[name] = time.perf_counter() - start
    if embeddings_available():
        start = time.perf_counter()
        runs["naive baseline: nearest label by MiniLM cosine"] = ddn.baseline(rows, graphs)
        seconds["naive baseline: nearest label by MiniLM cosine"] = time.perf_counter() - start
    lines = [
        "### DDN demand instructions in ScanNet object tables (written by others)",
        "",
        f"Validation split: {len(rows)} of its {total} instructions can be placed "
        "(`ddn_demands/SOURCE.md` protocol: a seeded scan holding an acceptable object and 8+ "
        "other labels; GT boxes and labels ingested). Right = non-empty and every object of "
        "an acceptable label; top-3 = an acceptable category among the first three ranked "
        "candidates. Development used the train split only; the need adapter "
        "(`scripts/train_need_adapter.py`) is learned on the train split, never on this one.",
        "",
        _row("reasoner", "n", "right", "top-3", "empty", "errors", "ms / instruction"),
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    data: dict[str, Any] = {"ddn/placed": len(rows), "ddn/total": total}
    for name, outs in runs.items():
        summ = ddn.summary(outs)
        data[f"ddn/{name}"] = summ
        lines.append(_row(name, summ["n"], _pct(summ["accuracy"]), _pct(summ["top3"]),
                          _pct(summ["empty"]), _pct(summ["errors"]),
                          f"{1000 * seconds[name] / max(1, len(outs)):.1f}"))  # fmt: skip
    absent = ddn.absent_placements("val")
    if quick:
        absent = absent[:60]
    reasoner = configs[-1][1]
    none = ddn.evaluate(absent, reasoner, graphs)
    rate = sum(o.empty for o in none) / max(1, len(none))
    placed_empty = data[f"ddn/{configs[-1][0]}"]["empty"]
    data["ddn/absent"] = {"n": len(none), "nothing": rate, "placed_empty": placed_empty}
    lines += [
        "",
        f"The same {len(none)} validation instructions, each in a seeded scan that holds no "
        "acceptable object (the right answer is nothing; the label map is partial, so some "
        f"scans still hold something that would do): {configs[-1][0]} answers nothing in "
        f"{_pct(rate)} of them, and in {_pct(placed_empty)} of the placed ones (where it "
        "should answer). The naive baseline always answers something.",
    ]
    lines += _ddn_commands(graphs, quick, configs[-1], embeddings_available(), data)
    return lines, data


def _ddn_commands(
    graphs: ref.ScanGraphs,
    quick: bool,
    config: tuple[str, Any],
    naive: bool,
    data: dict[str, Any],
) -> list[str]:
    """The validation instructions that open with a want, said as commands."""
    pairs = ddn.command_placements("val")
    if quick:
        pairs = pairs[:30]
    name, reasoner = config
    wants = ddn.summary(ddn.evaluate([w for w, _ in pairs], reasoner, graphs))
    commands = ddn.summary(ddn.evaluate([c for _, c in pairs], reasoner, graphs))
    data["ddn/commands"] = {"n": len(pairs), "want": wants, "command": commands}
    rows = [(f"{name}, said as a want (as written)", wants),
            (f"{name}, said as a command", commands)]  # fmt: skip
    if naive:
        baseline = ddn.summary(ddn.baseline([c for _, c in pairs], graphs))
        data["ddn/commands"]["naive"] = baseline
        rows.append(("naive baseline, said as a command", baseline))
    lines = [
        "",
        f'The {len(pairs)} validation instructions that open with a want ("I want to heat up '
        'my lunch"), asked as written and said as commands ("heat up my lunch"; '
        "`_reasoning_ddn.as_command`, a mechanical rewrite), in the same placements:",
        "",
        _row("reasoner", "n", "right", "top-3", "empty"),
        "|---|---:|---:|---:|---:|",
    ]
    for label, summ in rows:
        lines.append(_row(label, summ["n"], _pct(summ["accuracy"]), _pct(summ["top3"]),
                          _pct(summ["empty"])))  # fmt: skip
    return lines


#: Instructions of every reasoning level, asked of scene0000_00 (written for this report;
#: their answers are printed, not scored).
SHOWCASE: tuple[tuple[str, str], ...] = (
    ("commonsense", "Where can I heat up a bowl of soup quickly?"),
    ("commonsense", "Where can I wash my hands?"),
    ("commonsense", "I am exhausted and want to lie down for the night"),
    ("commonsense", "I need to dry myself off."),
    ("commonsense", "somewhere comfy to sit"),
    ("affordance", "I want to sit down near the kitchen counter"),
    ("affordance", "I need to throw something away next to the toilet"),
    ("spatial", "the pillow on the bed"),
    ("spatial", "the trash can closest to the toilet"),
    ("counterfactual", "if the bed is removed, what falls?"),
    ("counterfactual", "if the kitchen counter is removed, what falls?"),
    ("counterfactual", "what would fall if someone hauled the bed away?"),
    ("commonsense", "I just washed my hands, where can I dry them?"),
    ("commonsense", "which thing needs watering?"),
)


def _showcase(graphs: ref.ScanGraphs) -> tuple[list[str], dict[str, Any]]:
    from causalsplat.reason.offline import OfflineReasoner

    ctx = graphs.context("scene0000_00")
    reasoner = OfflineReasoner()
    lines = [
        "### Every level on scene0000_00 (GT objects; default offline reasoner)",
        "",
        _row("level", "instruction", "program type", "answer", "top candidates"),
        "|---|---|---|---|---|",
    ]
    data: dict[str, Any] = {}
    for level, text in SHOWCASE:
        answer = reasoner.answer(text, ctx)
        got = ", ".join(f"{c} #{i}" for c, i in zip(answer.categories, answer.entity_ids))
        top = ", ".join(f"{c.category} {c.score:.2f}" for c in answer.candidates[:3])
        lines.append(_row(level, text, answer.query_type, got or "(nothing)", top or "-"))
        data[f"showcase/{text}"] = {"type": answer.query_type, "answer": list(answer.categories)}
    return lines, data


def _synthetic(tmp: Path, quick: bool) -> tuple[list[str], dict[str, Any]]:
    from causalsplat.api import open_store
    from causalsplat.eval.reasoning import evaluate_queries, parse_queries
    from causalsplat.objects import objects_to_scene_graph, parse_objects
    from causalsplat.reason import SceneContext
    from causalsplat.reason.embed import embeddings_available
    from causalsplat.reason.offline import OfflineReasoner
    from causalsplat.synth import SynthConfig, generate_scene
    from causalsplat.synth.write import objects_document, queries_document

    presets = [("tiny", 0)] if quick else [("medium", 0), ("small", 0), ("small", 1), ("small", 2)]
    reasoners = {"lexical": OfflineReasoner(embeddings=False)}
    if embeddings_available():
        reasoners["lexical+embeddings"] = OfflineReasoner(embeddings=True)
    outcomes: dict[str, list[Any]] = {k: [] for k in reasoners}
    store = open_store(f"sqlite:///{tmp / 'synth.db'}")
    for size, seed in presets:
        scene = generate_scene(SynthConfig.preset(size, seed=seed))
        graph = objects_to_scene_graph(parse_objects(objects_document(scene)))
        store.save_scene(graph, gaussian_labels=scene.labels)
        ctx = SceneContext(
            graph, labels=lambda sid=graph.scene_id: store.graph_store.load_gaussian_labels(sid)
        )  # type: ignore[misc]
        queries = parse_queries(queries_document(scene))
        for name, reasoner in reasoners.items():
            outcomes[name] += evaluate_queries(ctx, queries, reasoner).per_query
    store.close()
    scenes = ", ".join(f"{s} seed {k}" for s, k in presets)
    lines = [
        "### Synthetic benchmark scenes",
        "",
        f"Scenes: {scenes} (GT entities ingested; 3D IoU on the GT per-Gaussian labels).",
        "",
        _row("reasoner", "level", "n", "accuracy", "3D mIoU"),
        "|---|---|---:|---:|---:|",
    ]
    data: dict[str, Any] = {}
    for name, outs in outcomes.items():
        for level in (*LEVELS, None):
            chosen = [o for o in outs if level is None or o.type == level]
            if not chosen:
                continue
            acc = sum(o.correct for o in chosen) / len(chosen)
            miou = sum(o.iou for o in chosen) / len(chosen)
            lines.append(
                f"| {name} | {level or '**all**'} | {len(chosen)} | {_pct(acc)} | {miou:.3f} |"
            )
            data[f"synth/{name}/{level or 'all'}"] = {
                "n": len(chosen),
                "accuracy": acc,
                "miou": miou,
            }
    return lines, data


def _timing(tmp: Path, quick: bool) -> tuple[list[str], dict[str, Any]]:
    """Cold and warm ``ask`` on scene0000_00 (GT objects), lexical only and with
    embeddings (the default when the embed extra is installed)."""
    from causalsplat.api import open_store
    from causalsplat.reason.embed import embeddings_available

    scan = "scene0000_00"
    # scene0000_00 is a ReferIt3D *train* scan: its utterances time the spatial path
    rows = ref.sr3d_rows("train", ("between", "vertical", "support", "allocentric"))
    rows += ref.nr3d_rows("train_sampled1000")
    spatial = [r.text for r in rows if r.scan == scan][: 10 if quick else 30]
    spatial = spatial or [text for level, text in SHOWCASE if level == "spatial"]
    needs = [text for level, text in SHOWCASE if level in ("commonsense", "affordance")]
    url = persist_scan(tmp, scan)
    repeats = 3 if quick else 5
    entities = len(ref.objects_document(scan)["objects"])
    data: dict[str, Any] = {"scan": scan, "entities": entities}
    lines = [
        "### Run time",
        "",
        f"Scene {scan} ({entities} entities, persisted in SQLite); median of {repeats} runs. "
        f"Cold: a fresh interpreter runs `causalsplat ask {needs[0]!r} --json` (wall and CPU "
        "time of the child process, with Python's bytecode cache as an installed package has "
        "it); warm: `scene.ask` in a running process.",
        "",
        _row("measurement", "wall", "CPU", "baseline", "ratio", "goal"),
        "|---|---:|---:|---:|---:|---|",
    ]
    configs: list[tuple[str, bool | None]] = [("lexical only (`--no-embeddings`)", False)]
    if embeddings_available():
        configs.append(("embeddings (default)", None))
    for label, flag in configs:
        cold = cold_ask(url, scan, needs[0], embeddings=flag, repeats=repeats)
        data[f"cold/{label}"] = {
            "ask_s": cold.ask_s,
            "cpu_s": cold.ask_cpu_s,
            "python_s": cold.python_s,
            "torch": cold.torch_imported,
        }
        lines.append(_row(
            f"cold `causalsplat ask`, {label}", f"{cold.ask_s:.2f} s", f"{cold.ask_cpu_s:.2f} s",
            f"`python -c pass` {cold.python_s:.2f} s", f"{cold.ask_s / cold.python_s:.1f}x",
            f"<= 1.0 CPU s, no torch (torch imported: {cold.torch_imported})",
        ))  # fmt: skip
    with open_store(url) as store:
        scene = store.scene(scan)
        for label, flag in configs:
            options = {} if flag is None else {"embeddings": flag}
            for what, texts in (("spatial utterances", spatial), ("needs", needs)):
                warm = warm_ask(scene, texts, repeats=repeats, **options)
                data[f"warm/{label}/{what}"] = {"ask_ms": warm.ask_ms,
                                                "executor_ms": warm.executor_ms}  # fmt: skip
                lines.append(_row(
                    f"warm `scene.ask`, {label}, {warm.n_queries} {what}",
                    f"{warm.ask_ms:.1f} ms", "",
                    f"program on the memory executor {warm.executor_ms:.2f} ms",
                    f"{warm.ask_ms / warm.executor_ms:.1f}x", "",
                ))  # fmt: skip
    return lines, data


#: The object attributes a build stores too (:mod:`causalsplat.graph.nodes`: the measured
#: colour and its name); the GT objects of the fidelity gap keep only these.
BUILT_ATTRIBUTES = frozenset({"color", "rgb"})


def as_a_build_knows(objects: Path, out: Path) -> Path:
    """A copy of the objects document ``objects`` at ``out`` whose objects keep only the
    attributes a build also stores (:data:`BUILT_ATTRIBUTES`), and ``out``.

    >>> import json, tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> doc = {"objects": [{"id": 1, "label": "table", "points": [[0, 0, 0]],
    ...         "attributes": {"color": "white", "affordance": ["dine"]}}]}
    >>> _ = (d / "objects.json").write_text(json.dumps(doc))
    >>> kept = json.loads(as_a_build_knows(d / "objects.json", d / "out.json").read_text())
    >>> kept["objects"][0]["attributes"]
    {'color': 'white'}
    """
    doc = json.loads(objects.read_text(encoding="utf-8"))
    for obj in doc.get("objects", []):
        if isinstance(obj.get("attributes"), dict):
            obj["attributes"] = {
                k: v for k, v in obj["attributes"].items() if k in BUILT_ATTRIBUTES
            }
    out.write_text(json.dumps(doc), encoding="utf-8")
    return out


def _built(tmp: Path, quick: bool) -> tuple[list[str], dict[str, Any]]:
    """Scenes built by the pipeline from Gaussians and noisy masks, scored against the GT
    labels of their Gaussians (the Causal-ScanNet protocol)."""
    from causalsplat.api import open_store
    from causalsplat.synth import synth_scene

    folders: list[tuple[str, Path]] = []
    small = tmp / "built-small"
    synth_scene("tiny" if quick else "small", 0, small)
    folders.append(("synthetic " + ("tiny" if quick else "small") + " (seed 0)", small))
    scannet = ref.DATA.parent / "scannet_scene0000_00"
    if not quick and scannet.exists():
        from causalsplat.scannet.prepare import prepare_scannet

        prepare_scannet(scannet, tmp / "built-scannet")
        folders.append(("ScanNet scene0000_00", tmp / "built-scannet"))
    lines = [
        "### Scenes built from Gaussians and noisy masks (`Store.build`, offline lexical reasoner)",
        "",
        "Each scene is built by the pipeline (default config), stored, and its queries file "
        "asked; answers are scored against the GT instance of every Gaussian "
        "(`causalsplat eval --gt-labels`): an entity stands for the GT instance holding most "
        "of its Gaussians, 3D IoU on the Gaussians. ScanNet queries are the scene's Sr3D, "
        "Nr3D and ScanRefer utterances with a target id (all of them: the scan is one scene). "
        "The GT-objects rows ask the same questions of the scene's ground-truth objects "
        "(`ingest-objects`; 3D IoU of the boxes), with only what a build knows of an object: "
        "its label, points and colour (attributes no build measures, such as the synthetic "
        "rooms' annotated affordances and materials, are left out, so that the gap is what "
        "the segmentation loses).",
        "",
        "| scene | level | n | accuracy | 3D mIoU |",
        "|---|---|---:|---:|---:|",
    ]
    data: dict[str, Any] = {}
    examples: list[str] = []
    showcase: list[str] = []
    gaps: list[str] = []
    with (
        open_store(f"sqlite:///{tmp / 'built.db'}") as store,
        open_store(f"sqlite:///{tmp / 'built-truth.db'}") as truths,
    ):
        for label, folder in folders:
            scene = store.build(folder, cache_dir=tmp / "cache")
            report = scene.evaluate(folder / "queries.json", gt_labels=folder / "gt/gt_labels.npy")
            for level, score in [*report.by_type.items(), ("**all**", report.overall)]:
                lines.append(f"| {label} | {level} | {score.n} | {_pct(score.accuracy)} "
                             f"| {score.miou:.3f} |")  # fmt: skip
            data[f"built/{label}"] = report.overall.to_dict()
            # the same questions on the scene's GT objects: what the build loses
            truth = truths.ingest_objects(
                as_a_build_knows(folder / "objects.json", tmp / f"{folder.name}-truth.json"),
                scene_id=scene.id,
            )
            on_truth = truth.evaluate(folder / "queries.json").overall
            lines.append(f"| {label}, GT objects (same questions) | **all** | {on_truth.n} "
                         f"| {_pct(on_truth.accuracy)} | {on_truth.miou:.3f} |")  # fmt: skip
            data[f"built/{label}/gt-objects"] = on_truth.to_dict()
            gap = 100 * (on_truth.accuracy - report.overall.accuracy)
            gaps.append(f"{label}: {_pct(on_truth.accuracy)} on its GT objects, "
                        f"{_pct(report.overall.accuracy)} built, a fidelity gap of "
                        f"{gap:.1f} points")  # fmt: skip
            if label.startswith("ScanNet"):
                for level, text in SHOWCASE:
                    answer = scene.ask(text)
                    pairs = zip(answer.categories, answer.entity_ids, strict=True)
                    got = ", ".join(f"{c} #{i}" for c, i in pairs)
                    showcase.append(_row(label, level, text, got or "(nothing)"))
            shown: dict[str, Any] = {}
            for o in report.per_query:
                shown.setdefault(o.type, o)
            examples += [
                _row(label, level, o.text, ", ".join(o.predicted) or "(nothing)",
                     ", ".join(o.targets), "yes" if o.correct else "no")
                for level, o in sorted(shown.items())
            ]  # fmt: skip
    lines += [
        "",
        "**Fidelity gap** (the same questions asked of the scene's GT objects, stored from its "
        "`objects.json`, in the same run; the gap is what the build loses): "
        + "; ".join(gaps)
        + ".",
        "",
        "One question of each level per built scene, with its answer (GT instance ids):",
        "",
        _row("scene", "level", "question", "answer", "target", "right"),
        "|---|---|---|---|---|---|",
        *examples,
    ]
    if showcase:
        lines += [
            "",
            "The instructions of every level of the scene0000_00 table above, asked of the "
            "graph built from its Gaussians (entity ids of the built graph):",
            "",
            _row("scene", "level", "instruction", "answer"),
            "|---|---|---|---|",
            *showcase,
        ]
    return lines, data


def run(*, quick: bool = False) -> BenchReport:
    data: dict[str, Any] = {}
    sections: list[str] = []
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        graphs = ref.ScanGraphs(f"sqlite:///{tmp / 'referit.db'}")
        if ddn.available():
            lines, part = _ddn(graphs, quick)
            sections += [*lines, ""]
            data.update(part)
            lines, part = _showcase(graphs)
            sections += [*lines, ""]
            data.update(part)
        if ref.DATA.exists():
            lines, part = _referit(graphs, quick, tmp)
            sections += lines
            data.update(part)
            lines, part = _timing(tmp, quick)
            sections += ["", *lines]
            data.update(part)
        else:
            sections.append(f"ReferIt3D data not found at {ref.DATA}: those sections were skipped.")
        graphs.close()
        lines, part = _synthetic(tmp, quick)
        sections += ["", *lines]
        data.update(part)
        lines, part = _built(tmp, quick)
        sections += ["", *lines]
        data.update(part)
    intro = (
        "The offline reasoner (rules, the shipped WordNet lexicon and knowledge table, "
        "sentence embeddings when installed; no network, no torch). Developed on DDN "
        "*train* instructions and Sr3D/Nr3D/ScanRefer *train* rows only; the figures "
        "below are DDN *validation* and ReferIt3D *test* rows (ScanRefer: sampled val)."
    )
    return BenchReport(NAME, "Reasoning", "\n".join([intro, "", *sections]), data)
