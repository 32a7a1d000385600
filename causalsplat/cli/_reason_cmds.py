"""Reasoning commands: ``ask`` (one instruction) and ``eval`` (a queries file)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from causalsplat.cli._app import SECONDS, cli, db_option, echo_json, entity_line, json_option
from causalsplat.cli._scene_select import scene_choice, scene_options

_REASONERS = ("offline", "vlm")


def _options(
    reasoner: str,
    embeddings: bool | None,
    base_url: str | None,
    model: str | None,
    timeout: float | None,
    max_tokens: str | None,
    record: Path | None,
    replay: Path | None,
) -> dict[str, Any]:
    if reasoner == "offline":
        if record or replay or base_url or model or max_tokens:
            raise click.UsageError(
                "--base-url/--model/--max-tokens/--record/--replay need --reasoner vlm"
            )
        return {} if embeddings is None else {"embeddings": embeddings}
    from causalsplat.openai_compat import VLMConfig, parse_max_tokens

    # Parsed here, not by click, so a bad value is one line on stderr (a CausalSplatError).
    budget = None if max_tokens is None else parse_max_tokens(max_tokens, "--max-tokens")
    config = VLMConfig.from_env(
        base_url=base_url, model=model, timeout_s=timeout, max_tokens=budget
    )
    out: dict[str, Any] = {"config": config, "record": record, "replay": replay}
    return {k: v for k, v in out.items() if v is not None}


def _scene_option(func: Any) -> Any:
    return click.option("--scene", "scene_id", required=True, help="Id of the stored scene.")(func)


def _reasoner_options(func: Any) -> Any:
    options = [
        click.option(
            "--reasoner",
            type=click.Choice(_REASONERS),
            default="offline",
            show_default=True,
            help="offline: deterministic rules; vlm: an OpenAI-compatible server.",
        ),
        click.option(
            "--embeddings/--no-embeddings",
            default=None,
            help="Offline reasoner: score meaning with sentence embeddings (needs the embed"
            " extra) or with WordNet word overlap only; default: embeddings when installed.",
        ),
        click.option("--base-url", help="VLM server API root ($CAUSALSPLAT_VLM_BASE_URL)."),
        click.option("--model", help="VLM model name ($CAUSALSPLAT_VLM_MODEL)."),
        click.option("--timeout", type=SECONDS, help="VLM reply timeout in seconds (60)."),
        click.option(
            "--max-tokens",
            metavar="N",
            help="VLM reply token budget, a positive integer ($CAUSALSPLAT_VLM_MAX_TOKENS,"
            " default 1024); a retry after a cut-off reply asks for twice as many.",
        ),
        click.option(
            "--record",
            type=click.Path(dir_okay=False, path_type=Path),
            help="Append every VLM exchange to this JSONL file.",
        ),
        click.option(
            "--replay",
            type=click.Path(exists=True, dir_okay=False, path_type=Path),
            help="Answer VLM requests from this JSONL recording (no network).",
        ),
        click.option(
            "--allow-fallback",
            is_flag=True,
            help="Exit 0 when the VLM could not answer and the offline reasoner did (by"
            " default the answer is printed, stderr says why, and the exit status is 3).",
        ),
        db_option,
        json_option,
    ]
    for option in reversed(options):
        func = option(func)
    return func


@cli.command("ask")
@click.argument("text")
@scene_options
@_reasoner_options
def ask(
    text: str,
    scene_id: str | None,
    scenes_glob: str | None,
    all_scenes: bool,
    reasoner: str,
    embeddings: bool | None,
    base_url: str | None,
    model: str | None,
    timeout: float | None,
    max_tokens: str | None,
    record: Path | None,
    replay: Path | None,
    allow_fallback: bool,
    db_url: str,
    as_json: bool,
) -> None:
    """Answer an instruction about a stored scene (offline rules or a VLM).

    Prints the answer's entities and an explanation; --json prints
    {"query", "program", "answer", "entities", "explanation", "reasoner", ...}.

    With --all-scenes or --scenes GLOB the instruction is answered on every selected scene
    (each on its own: grounding depends on the scene's categories); the output lists the
    scenes with a non-empty answer and a count line, --json every scene's answer.
    """
    from causalsplat.api import open_store
    from causalsplat.reason import entity_documents

    choice = scene_choice(scene_id, scenes_glob, all_scenes)
    options = _options(reasoner, embeddings, base_url, model, timeout, max_tokens, record, replay)
    if choice.many:
        answers = _ask_many(text, choice.selection, reasoner, options, db_url, as_json)
        _fell_back([a.fallback for a in answers], allow_fallback, ("instruction", "scenes"))
        return
    assert scene_id is not None
    with open_store(db_url, create=False) as store:
        scene = store.scene(scene_id)
        answer = scene.ask(text, reasoner=reasoner, **options)
        entities = entity_documents(answer, {e.id: e for e in scene.entities})
    if as_json:
        echo_json(answer.to_dict(entities=entities))
    else:
        _print_answer(answer, entities)
    _fell_back([answer.fallback], allow_fallback, ("instruction", "instructions"))


def _print_answer(answer: Any, entities: list[dict[str, Any]]) -> None:
    how = answer.reasoner + (f" (fallback from {answer.requested})" if answer.fell_back else "")
    click.echo(f"{answer.query_type} query, answered by {how}")
    if answer.value is not None:
        click.echo(f"answer: {answer.value}")
    if answer.nothing_fits:
        click.echo("nothing here fits (the explanation says why; closest candidates below)")
    elif not entities:
        click.echo("no entity")
    for e in entities:
        click.echo(entity_line(e["id"], e["category"], e["external_id"]))
    if answer.candidates:
        click.echo("candidates (best first):")
        for rank, c in enumerate(answer.candidates, 1):
            mark = "*" if c.chosen else " "
            ids = ",".join(str(i) for i in c.entity_ids[:6]) + (
                ",..." if len(c.entity_ids) > 6 else ""
            )
            click.echo(f" {mark}{rank}. {c.category:<22} {c.score:5.2f}  [{ids}]  "
                       f"{'; '.join(c.evidence)}")  # fmt: skip
    click.echo(answer.explanation)


def _ask_many(
    text: str,
    selection: str | None,
    reasoner: str,
    options: dict[str, Any],
    db_url: str,
    as_json: bool,
) -> list[Any]:
    """``ask`` over many scenes: every answer with --json, else the non-empty ones; the
    answers."""
    from causalsplat.api import open_store

    with open_store(db_url, create=False) as store:
        answers = store.ask_all(text, scenes=selection, reasoner=reasoner, **options)
    answered = [a for a in answers.values() if a.entity_ids or a.value]
    if as_json:
        results = []
        for a in answers.values():
            ents = [
                {"id": i, "external_id": x, "category": c}
                for i, x, c in zip(a.entity_ids, a.external_ids, a.categories, strict=True)
            ]
            results.append(a.to_dict(entities=ents))
        echo_json(
            {"query": text, "scenes": len(answers), "answered": len(answered), "results": results}
        )
        return list(answers.values())
    for a in answered:
        head = f"{a.scene_id}: {a.query_type}"
        if a.value is not None:
            head += f", answer {a.value}"
        click.echo(f"{head}, {len(a.entity_ids)} entit{'y' if len(a.entity_ids) == 1 else 'ies'}")
        for i, x, c in zip(a.entity_ids, a.external_ids, a.categories, strict=True):
            click.echo(entity_line(i, c, x))
    click.echo(f"{len(answered)} of {len(answers)} scenes answered")
    return list(answers.values())


#: Exit status of ``ask`` and ``eval`` when the requested reasoner could not answer and the
#: offline one did (without --allow-fallback): the output is complete, but not what was
#: asked for.
FELL_BACK_EXIT = 3


def _fell_back(fallbacks: list[str | None], allowed: bool, what: tuple[str, str]) -> None:
    """Say on stderr when the requested reasoner could not answer, and exit with
    :data:`FELL_BACK_EXIT` unless that was allowed."""
    why = [f for f in fallbacks if f is not None]
    if not why:
        return
    n = len(fallbacks)
    count = f"{len(why)} of {n} {what[1]} were" if n > 1 else f"the {what[0]} was"
    click.echo(
        f"causalsplat: the VLM could not answer ({why[0]}): {count} answered by the offline"
        " reasoner" + ("" if allowed else "; pass --allow-fallback to accept that"),
        err=True,
    )
    if not allowed:
        raise SystemExit(FELL_BACK_EXIT)


@cli.command("eval")
@click.argument("queries_file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option(
    "--gt-labels",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    help="GT instance id per Gaussian (.npy, e.g. a scene folder's gt/gt_labels.npy): score "
    "a built scene against its ground truth; targets are then GT instance ids.",
)
@_scene_option
@_reasoner_options
def evaluate(
    queries_file: Path,
    gt_labels: Path | None,
    scene_id: str,
    reasoner: str,
    embeddings: bool | None,
    base_url: str | None,
    model: str | None,
    timeout: float | None,
    max_tokens: str | None,
    record: Path | None,
    replay: Path | None,
    allow_fallback: bool,
    db_url: str,
    as_json: bool,
) -> None:
    """Accuracy and 3D mIoU of a reasoner over a queries file, per reasoning type.

    --json prints {"n", "accuracy", "miou", "by_type": {type: {"n", "accuracy", "miou"}},
    "per_query": [...], "instances"}; with --gt-labels, "instances" holds the stored
    entities' quality against the GT instances as `build --json` reports it (mean best IoU,
    AP50/AP25, PQ/SQ/RQ, split, merged, missed, extra), else null.
    """
    from causalsplat.api import open_store

    options = _options(reasoner, embeddings, base_url, model, timeout, max_tokens, record, replay)
    with open_store(db_url, create=False) as store:
        report = store.scene(scene_id).evaluate(
            queries_file, reasoner=reasoner, gt_labels=gt_labels, **options
        )
    if as_json:
        echo_json(report.to_dict())
    else:
        _print_report(report)
    _fell_back([o.fallback for o in report.per_query], allow_fallback, ("query", "queries"))


def _print_report(report: Any) -> None:
    click.echo(
        f"scene {report.scene_id}, reasoner {report.reasoner}, IoU on {report.iou_basis}:"
        f" {report.n} queries, accuracy {report.accuracy:.3f}, mIoU {report.miou:.3f}"
    )
    for qtype, score in report.by_type.items():
        click.echo(
            f"  {qtype:<15} n={score.n:<4} accuracy {score.accuracy:.3f}  mIoU {score.miou:.3f}"
            f"  F1 {score.f1:.3f}"
        )
    if report.instances is not None:
        from causalsplat.cli._build_cmd import panoptic_line

        q = report.instances.to_json()
        click.echo(
            f"  entities vs GT labels: {q['n_pred']} for {q['n_gt']} GT instances, mean best "
            f"IoU {q['mean_best_iou']:.3f}, AP50 {q['ap50']:.3f}, AP25 {q['ap25']:.3f}; "
            f"{panoptic_line(q)}"
        )
    wrong = [o for o in report.per_query if not o.correct]
    for o in wrong:
        why = o.error or f"got {list(o.predicted)}, expected {list(o.targets)}"
        click.echo(f"  wrong {o.id} ({o.type}): {o.text!r}: {why}")
