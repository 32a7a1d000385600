"""Evaluating a reasoner on a queries file (DESIGN §9, §11): accuracy, 3D IoU, F1.

A query is **correct** when the predicted entity set equals its ``targets`` (external ids).
Its **3D IoU** is measured on what the scene holds:

* per-Gaussian labels (scenes built from a Gaussian field, or stored with labels): IoU of
  the predicted and target Gaussian masks;
* otherwise the entities' point counts (``ingest-objects`` scenes with points): the points
  of different objects are disjoint, so IoU = shared points / points of the union;
* otherwise (no points either) each entity counts one: the Jaccard index of the id sets.

Scenes built by the pipeline have no external ids; they are scored against the folder's
ground truth instead (``gt_labels``: the GT instance id of every Gaussian, as in
``gt/gt_labels.npy``, targets being GT ids). Each entity then stands for the GT instance
holding most of its Gaussians; a query is correct when the set of GT instances of the
predicted entities is the target set, and its IoU is that of the predicted entities'
Gaussians with the target instances' Gaussians (the Causal-ScanNet protocol).

Both sets empty gives IoU 1. **F1** compares the id sets (precision and recall of the
predicted entities; 1 when both are empty). Reports break every number down by the
query's reasoning type. The ReferIt3D protocols (one target per utterance) and ScanRefer's
Acc@k (box IoU >= k) are :func:`referit_correct` and :func:`box_iou`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from causalsplat._json import JSONInputError, decode_json
from causalsplat.reason.errors import QueriesFileError, ReasonError
from graph_store.errors import GraphStoreError
from queries.errors import QueryError

if TYPE_CHECKING:
    import numpy as np

    from causalsplat.instances.quality import InstanceQuality
    from causalsplat.reason.context import SceneContext
    from causalsplat.reason.reasoner import Reasoner

QUERY_TYPES = ("intrinsic", "spatial", "commonsense", "affordance", "counterfactual")


# -- metrics -----------------------------------------------------------------------------


def set_iou(
    predicted: Iterable[int], target: Iterable[int], weights: Mapping[int, float] | None = None
) -> float:
    """IoU of two entity sets, each entity weighted (its point count) or counting one."""
    p, t = set(predicted), set(target)
    if not p and not t:
        return 1.0

    def w(ids: set[int]) -> float:
        return math.fsum(weights.get(i, 0.0) if weights is not None else 1.0 for i in ids)

    union = w(p | t)
    return w(p & t) / union if union > 0 else 0.0


def mask_iou(predicted: np.ndarray, target: np.ndarray) -> float:
    """IoU of two boolean masks of the same shape (1 when both are empty)."""
    if predicted.shape != target.shape:
        raise ValueError(f"mask shapes differ: {predicted.shape} vs {target.shape}")
    union = int((predicted | target).sum())
    return 1.0 if union == 0 else int((predicted & target).sum()) / union


def set_f1(predicted: Iterable[int], target: Iterable[int]) -> float:
    """F1 of a predicted id set against the target set (1 when both are empty)."""
    p, t = set(predicted), set(target)
    if not p and not t:
        return 1.0
    hit = len(p & t)
    if hit == 0:
        return 0.0
    precision, recall = hit / len(p), hit / len(t)
    return 2 * precision * recall / (precision + recall)


def box_iou(
    a_min: Sequence[float], a_max: Sequence[float], b_min: Sequence[float], b_max: Sequence[float]
) -> float:
    """IoU of two axis-aligned 3D boxes (0 when their union has no volume)."""
    inter = 1.0
    for k in range(3):
        inter *= max(0.0, min(a_max[k], b_max[k]) - max(a_min[k], b_min[k]))
    va = math.prod(max(0.0, a_max[k] - a_min[k]) for k in range(3))
    vb = math.prod(max(0.0, b_max[k] - b_min[k]) for k in range(3))
    union = va + vb - inter
    return inter / union if union > 0 else 0.0


def referit_correct(predicted: Sequence[int], target: int) -> bool:
    """ReferIt3D: correct when the reasoner names exactly the target object."""
    return len(predicted) == 1 and predicted[0] == target


# -- queries files -----------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Query:
    """One query of a queries file; ``targets`` are external ids (as text)."""

    id: str
    text: str
    type: str
    targets: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class QueriesFile:
    scene_id: str | None
    queries: tuple[Query, ...]
    source: str


def read_queries(path: str | Path) -> QueriesFile:
    """Read and validate a queries file; raises :class:`QueriesFileError` naming the file
    and the bad field."""
    path = Path(path)
    try:
        document = decode_json(path.read_bytes())
    except JSONInputError as exc:
        raise QueriesFileError(f"{path}: {exc}") from None
    return parse_queries(document, source=str(path))


def parse_queries(document: Any, *, source: str = "<queries>") -> QueriesFile:
    if not isinstance(document, dict) or not isinstance(document.get("queries"), list):
        raise QueriesFileError(f"{source}: expected an object with a 'queries' list")
    if not document["queries"]:
        raise QueriesFileError(f"{source}: the 'queries' list is empty: nothing to evaluate")
    scene_id = document.get("scene_id")
    if scene_id is not None and not isinstance(scene_id, str):
        raise QueriesFileError(f"{source}: scene_id must be a string, got {scene_id!r}")
    out: list[Query] = []
    seen: set[str] = set()
    for i, q in enumerate(document["queries"]):
        where = f"{source}: queries[{i}]"
        if not isinstance(q, dict):
            raise QueriesFileError(f"{where}: must be an object")
        qid, text, qtype = q.get("id", str(i)), q.get("text"), q.get("type", "spatial")
        targets = q.get("targets")
        if not isinstance(qid, str) or qid in seen:
            raise QueriesFileError(f"{where}.id: must be a unique string, got {qid!r}")
        if not isinstance(text, str) or not text.strip():
            raise QueriesFileError(f"{where}.text: must be a non-empty string")
        if qtype not in QUERY_TYPES:
            raise QueriesFileError(f"{where}.type: {qtype!r} is not one of {QUERY_TYPES}")
        if not isinstance(targets, list) or not all(
            isinstance(t, int | str) and not isinstance(t, bool) for t in targets
        ):
            raise QueriesFileError(f"{where}.targets: must be a list of ids")
        seen.add(qid)
        out.append(Query(qid, text, qtype, tuple(str(t) for t in targets)))
    return QueriesFile(scene_id, tuple(out), source)


# -- evaluation --------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class QueryOutcome:
    """How one query went. ``predicted`` are external ids; ``error`` is the message of a
    reasoner error (the query then counts as wrong with IoU 0)."""

    id: str
    text: str
    type: str
    targets: tuple[str, ...]
    predicted: tuple[str, ...]
    correct: bool
    iou: float
    f1: float
    reasoner: str | None
    fallback: str | None
    error: str | None
    seconds: float

    def to_dict(self) -> dict[str, Any]:
        return {
            "id": self.id, "text": self.text, "type": self.type,
            "targets": list(self.targets), "predicted": list(self.predicted),
            "correct": self.correct, "iou": self.iou, "f1": self.f1,
            "reasoner": self.reasoner, "fallback": self.fallback, "error": self.error,
            "seconds": self.seconds,
        }  # fmt: skip


@dataclass(frozen=True, slots=True)
class Score:
    """Mean figures over a group of queries."""

    n: int
    accuracy: float
    miou: float
    f1: float

    @classmethod
    def of(cls, outcomes: Sequence[QueryOutcome]) -> Score:
        n = len(outcomes)
        if n == 0:
            return cls(0, 0.0, 0.0, 0.0)
        return cls(
            n,
            sum(o.correct for o in outcomes) / n,
            math.fsum(o.iou for o in outcomes) / n,
            math.fsum(o.f1 for o in outcomes) / n,
        )

    def to_dict(self) -> dict[str, Any]:
        return {"n": self.n, "accuracy": self.accuracy, "miou": self.miou, "f1": self.f1}


@dataclass(frozen=True, slots=True)
class EvalReport:
    """The numbers of ``causalsplat eval`` (DESIGN §10)."""

    scene_id: str
    reasoner: str
    iou_basis: str
    overall: Score
    by_type: dict[str, Score]
    per_query: tuple[QueryOutcome, ...] = field(default=())
    #: With GT labels: the stored entities against the GT instances, as ``build`` reports
    #: it (mean best IoU, AP, PQ / SQ / RQ, split, merged, missed, extra).
    instances: InstanceQuality | None = None

    @property
    def n(self) -> int:
        return self.overall.n

    @property
    def accuracy(self) -> float:
        return self.overall.accuracy

    @property
    def miou(self) -> float:
        return self.overall.miou

    def to_dict(self) -> dict[str, Any]:
        return {
            "scene_id": self.scene_id,
            "reasoner": self.reasoner,
            "iou_basis": self.iou_basis,
            "n": self.overall.n,
            "accuracy": self.overall.accuracy,
            "miou": self.overall.miou,
            "f1": self.overall.f1,
            "fallbacks": sum(o.fallback is not None for o in self.per_query),
            "errors": sum(o.error is not None for o in self.per_query),
            "by_type": {t: s.to_dict() for t, s in self.by_type.items()},
            "per_query": [o.to_dict() for o in self.per_query],
            "instances": None if self.instances is None else self.instances.to_json(),
        }


def iou_basis(ctx: SceneContext) -> str:
    """``gaussians``, ``points`` or ``entities`` (module docstring)."""
    if ctx.gaussian_labels() is not None:
        return "gaussians"
    if ctx.by_id and all(e.point_count > 0 for e in ctx.by_id.values()):
        return "points"
    return "entities"


def evaluate_queries(
    ctx: SceneContext,
    queries: QueriesFile,
    reasoner: Reasoner,
    *,
    name: str | None = None,
    gt_labels: np.ndarray | None = None,
    check_scene_id: bool = True,
) -> EvalReport:
    """Ask every query of ``queries`` on ``ctx`` with ``reasoner`` and score the answers.

    With ``gt_labels`` the scene is scored against the ground truth of its Gaussians
    (module docstring). Raises :class:`QueriesFileError` when the file names another scene
    (unless ``check_scene_id=False``) or a target the scene does not hold; a reasoner error
    on one query makes that query wrong."""
    if check_scene_id and queries.scene_id is not None and queries.scene_id != ctx.scene_id:
        raise QueriesFileError(
            f"{queries.source}: queries are for scene {queries.scene_id!r}, not {ctx.scene_id!r}"
        )
    if gt_labels is not None:
        return _evaluate_against_gt(ctx, queries, reasoner, name, gt_labels)
    local = {e.external_id: e.id for e in ctx.by_id.values() if e.external_id is not None}
    for q in queries.queries:
        for t in q.targets:
            if t not in local:
                hint = (
                    "; targets are external ids of stored entities (objects files): for a"
                    " scene built from Gaussians, score against GT instances with"
                    " --gt-labels FILE.npy"
                    if not local
                    else ""
                )
                raise QueriesFileError(
                    f"{queries.source}: query {q.id!r}: target {t!r} is not in scene"
                    f" {ctx.scene_id!r}{hint}"
                )
    basis = iou_basis(ctx)
    scorer = _IouScorer(ctx, basis)
    outcomes = [_ask_one(ctx, q, reasoner, local, scorer) for q in queries.queries]
    by_type = {t: Score.of([o for o in outcomes if o.type == t]) for t in QUERY_TYPES}
    by_type = {t: s for t, s in by_type.items() if s.n}
    return EvalReport(
        ctx.scene_id,
        name or getattr(reasoner, "name", type(reasoner).__name__),
        basis,
        Score.of(outcomes),
        by_type,
        tuple(outcomes),
    )


def _evaluate_against_gt(
    ctx: SceneContext,
    queries: QueriesFile,
    reasoner: Reasoner,
    name: str | None,
    gt_labels: np.ndarray,
) -> EvalReport:
    import numpy as np

    from causalsplat.instances.quality import scene_quality

    labels = ctx.gaussian_labels()
    gt = np.asarray(gt_labels)
    if labels is None:
        raise QueriesFileError(
            f"scene {ctx.scene_id!r} stores no per-Gaussian labels to compare with GT labels"
        )
    if gt.shape != labels.shape or gt.dtype.kind not in "iu":
        raise QueriesFileError(
            f"GT labels of shape {gt.shape} ({gt.dtype}) for a scene of {labels.shape[0]}"
            " Gaussians; expected one integer per Gaussian"
        )
    present = {str(int(i)) for i in np.unique(gt[gt >= 0])}
    for q in queries.queries:
        missing = [t for t in q.targets if t not in present]
        if missing:
            raise QueriesFileError(
                f"{queries.source}: query {q.id!r}: target(s) {missing} label no Gaussian"
            )
    # entity -> the GT instance holding most of its Gaussians
    stand_for: dict[int, str] = {}
    for e in ctx.by_id.values():
        own = gt[labels == e.id]
        own = own[own >= 0]
        if own.size:
            values, counts = np.unique(own, return_counts=True)
            stand_for[e.id] = str(int(values[np.argmax(counts)]))
    outcomes = []
    for q in queries.queries:
        start = time.perf_counter()
        target_mask = np.isin(gt, np.asarray([int(t) for t in q.targets], dtype=gt.dtype))
        try:
            answer = reasoner.answer(q.text, ctx)
        except (ReasonError, QueryError, GraphStoreError) as exc:
            outcomes.append(
                QueryOutcome(
                    q.id,
                    q.text,
                    q.type,
                    q.targets,
                    (),
                    False,
                    mask_iou(np.zeros_like(target_mask), target_mask),
                    0.0,
                    None,
                    None,
                    str(exc),
                    time.perf_counter() - start,
                )
            )
            continue
        seconds = time.perf_counter() - start
        predicted = list(answer.entity_ids)
        as_gt = tuple(stand_for.get(i, f"#{i}") for i in predicted)
        pred_mask = np.isin(labels, np.asarray(predicted, dtype=labels.dtype))
        outcomes.append(
            QueryOutcome(
                q.id,
                q.text,
                q.type,
                q.targets,
                as_gt,
                set(as_gt) == set(q.targets),
                mask_iou(pred_mask, target_mask),
                set_f1(as_gt, q.targets),
                answer.reasoner,
                answer.fallback,
                None,
                seconds,
            )
        )
    by_type = {t: Score.of([o for o in outcomes if o.type == t]) for t in QUERY_TYPES}
    return EvalReport(
        ctx.scene_id,
        name or getattr(reasoner, "name", type(reasoner).__name__),
        "gaussians (GT labels)",
        Score.of(outcomes),
        {t: s for t, s in by_type.items() if s.n},
        tuple(outcomes),
        scene_quality(labels, gt),
    )


class _IouScorer:
    def __init__(self, ctx: SceneContext, basis: str) -> None:
        self.basis = basis
        self.labels = ctx.gaussian_labels() if basis == "gaussians" else None
        self.weights = (
            {e.id: float(e.point_count) for e in ctx.by_id.values()} if basis == "points" else None
        )

    def __call__(self, predicted: Sequence[int], target: Sequence[int]) -> float:
        if self.labels is not None:
            import numpy as np

            p = np.isin(self.labels, np.asarray(predicted, dtype=self.labels.dtype))
            t = np.isin(self.labels, np.asarray(target, dtype=self.labels.dtype))
            return mask_iou(p, t)
        return set_iou(predicted, target, self.weights)


def _ask_one(
    ctx: SceneContext,
    q: Query,
    reasoner: Reasoner,
    local: Mapping[str, int],
    scorer: _IouScorer,
) -> QueryOutcome:
    target_ids = sorted(local[t] for t in q.targets)
    start = time.perf_counter()
    try:
        answer = reasoner.answer(q.text, ctx)
    except (ReasonError, QueryError, GraphStoreError) as exc:
        seconds = time.perf_counter() - start
        return QueryOutcome(q.id, q.text, q.type, q.targets, (), False, 0.0,
                            set_f1((), target_ids), None, None, str(exc), seconds)  # fmt: skip
    seconds = time.perf_counter() - start
    predicted = list(answer.entity_ids)
    external = tuple(
        e if e is not None else f"#{i}" for e, i in zip(answer.external_ids, predicted)
    )
    return QueryOutcome(
        q.id, q.text, q.type, q.targets, external,
        sorted(predicted) == target_ids,
        scorer(predicted, target_ids),
        set_f1(predicted, target_ids),
        answer.reasoner, answer.fallback, None, seconds,
    )  # fmt: skip
