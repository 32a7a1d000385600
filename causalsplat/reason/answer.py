"""What a reasoner returns: :class:`Answer` (stage 3 of the method, the decision)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from queries import GraphQuery, QueryResult

if TYPE_CHECKING:
    from collections.abc import Mapping

    import numpy as np

    from causalsplat.reason.context import SceneContext
    from graph_store import Entity


@dataclass(frozen=True, slots=True)
class ScoredCandidate:
    """One candidate category of an answer, ranked by how well it fits the instruction.

    Attributes:
        category: the category.
        score: its grounding score (higher fits better; see :mod:`causalsplat.reason.ground`).
        entity_ids: the scene's entities of that category (local ids, ascending).
        chosen: whether the answer's program selected it.
        evidence: why: the description that matched (or the words that named it), then
            what the relations did with it.
    """

    category: str
    score: float
    entity_ids: tuple[int, ...]
    chosen: bool
    evidence: tuple[str, ...]

    def to_dict(self) -> dict[str, Any]:
        return {
            "category": self.category,
            "score": round(self.score, 4),
            "entities": list(self.entity_ids),
            "chosen": self.chosen,
            "evidence": list(self.evidence),
        }


@dataclass(frozen=True, slots=True)
class Answer:
    """The answer to one instruction on one scene.

    Attributes:
        query: the instruction, as asked.
        scene_id: the scene it was asked about.
        program: the structured program that produced the answer (stages 1-2).
        result: the program's result (every step's value; support paths of
            counterfactuals).
        entity_ids: the answer's entities (local ids, ascending); for a ``count`` /
            ``exists`` program, the entities counted.
        external_ids: each entity's external id (``None`` where it has none), in the
            order of ``entity_ids``.
        categories: each entity's category, in the order of ``entity_ids``.
        value: the answer of a ``count`` (int) or ``exists`` (bool) program, else ``None``.
        gaussian_mask: ``(N,)`` bool, one per Gaussian of the scene, True for the Gaussians
            of the answer's entities; ``None`` when the scene has no per-Gaussian labels.
        explanation: how the answer was reached, in words, then the program's text form
            with each step's result.
        reasoner: the backend that produced the program (``offline`` or ``vlm``).
        requested: the backend that was asked (differs from ``reasoner`` after a fallback).
        fallback: why the requested backend's answer was not used, or ``None``.
        candidates: the ranked candidate categories with their scores and evidence, best
            first (empty when the instruction names its target outright and nothing else
            was scored).
    """

    query: str
    scene_id: str
    program: GraphQuery
    result: QueryResult
    entity_ids: tuple[int, ...]
    external_ids: tuple[str | None, ...]
    categories: tuple[str, ...]
    value: int | bool | None
    explanation: str
    reasoner: str
    requested: str
    fallback: str | None = None
    candidates: tuple[ScoredCandidate, ...] = ()
    gaussian_mask: np.ndarray | None = field(default=None, compare=False, repr=False)

    @property
    def query_type(self) -> str:
        return self.program.query_type.value

    @property
    def fell_back(self) -> bool:
        return self.fallback is not None

    @property
    def nothing_fits(self) -> bool:
        """Nothing in the scene fits what was asked (an empty set answer that is not a
        counterfactual's "nothing falls"); :attr:`candidates` then holds what came
        closest and :attr:`explanation` says what the scene contradicts."""
        return not self.entity_ids and self.value is None and self.query_type != "counterfactual"

    def to_dict(self, *, entities: list[dict[str, Any]] | None = None) -> dict[str, Any]:
        """The JSON document of ``causalsplat ask --json`` (DESIGN §10)."""
        return {
            "query": self.query,
            "scene_id": self.scene_id,
            "query_type": self.query_type,
            "program": self.program.to_dict(),
            "program_text": self.program.to_text(),
            "answer": list(self.entity_ids),
            "value": self.value,
            "entities": entities if entities is not None else [],
            "explanation": self.explanation,
            "reasoner": self.reasoner,
            "requested": self.requested,
            "fallback": self.fallback,
            "nothing_fits": self.nothing_fits,
            "candidates": [c.to_dict() for c in self.candidates],
            "gaussians": None if self.gaussian_mask is None else int(self.gaussian_mask.sum()),
        }


def make_answer(
    ctx: SceneContext,
    query: str,
    result: QueryResult,
    *,
    explanation: str,
    reasoner: str,
    requested: str | None = None,
    fallback: str | None = None,
    candidates: tuple[ScoredCandidate, ...] = (),
) -> Answer:
    """An :class:`Answer` from a program's result on a scene (fills ids, categories, mask)."""
    program = result.program
    if isinstance(result.answer, tuple):
        ids, value = result.answer, None
    else:
        last_set = program.answer.inputs[0]
        counted = result.steps[last_set]
        ids = counted if isinstance(counted, tuple) else ()
        value = result.answer
    entities = [ctx.by_id[i] for i in ids]
    mask = None
    labels = ctx.gaussian_labels()
    if labels is not None:
        import numpy as np

        mask = np.isin(labels, np.asarray(ids, dtype=labels.dtype))
    return Answer(
        query=query,
        scene_id=ctx.scene_id,
        program=program,
        result=result,
        entity_ids=tuple(ids),
        external_ids=tuple(e.external_id for e in entities),
        categories=tuple(e.category for e in entities),
        value=value,
        explanation=explanation,
        reasoner=reasoner,
        requested=requested or reasoner,
        fallback=fallback,
        candidates=candidates,
        gaussian_mask=mask,
    )


def entity_documents(answer: Answer, entities: Mapping[int, Entity]) -> list[dict[str, Any]]:
    """``{"id", "external_id", "category", "centroid", "bbox_min", "bbox_max",
    "point_count"}`` for each entity of the answer (``entities``: the scene's, by id)."""
    out = []
    for i in answer.entity_ids:
        e = entities[i]
        out.append(
            {
                "id": e.id,
                "external_id": e.external_id,
                "category": e.category,
                "centroid": list(e.centroid),
                "bbox_min": list(e.bbox_min),
                "bbox_max": list(e.bbox_max),
                "point_count": e.point_count,
            }
        )
    return out
