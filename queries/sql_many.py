"""The SQL executor over many scenes: one program, one statement, every selected scene.

The steps compile as in :mod:`queries.sql_executor`, but every CTE carries
``(scene_id, id)`` (:mod:`queries._sql_many_steps`), so the database evaluates the program
once for all selected scenes and the final ``SELECT`` returns ``(step, scene_id, id)``
rows, split per scene in Python; ``count`` and ``exists`` are grouped per scene with the
selected scenes as the outer side, so a scene with nothing to count still answers 0.
``fall_if_removed`` reads the support edges of the scenes with something removed in one
statement and runs the fixpoint of each scene in Python with the reference rule (one
statement per round, as the per-scene executor does, costs a round trip with ever longer
id lists per round: seconds over 1,500 scans); each scene's rounds, fallen entities and
support paths are exactly those of a run on that scene alone. The answers
are equal to :class:`~queries.sql_executor.SqlExecutor`'s on each scene.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Sequence
from typing import Any

import sqlalchemy as sa
from sqlalchemy.engine import Connection, Engine

from queries._sql_many_steps import Pair, SqlManySteps
from queries._sql_steps import compile_shared
from queries.errors import QueryExecutionError
from queries.model import GraphQuery, Op, Step
from queries.result import QueryResult, StepValue
from queries.semantics import (
    DEFAULT_CONFIG,
    QueryConfig,
    SupportPath,
    fall_rounds,
    support_paths,
)
from queries.sql_executor import raw_rows

EXECUTOR_NAME = "sql"


def run_sql_many(
    engine: Engine,
    scene_ids: Sequence[str],
    program: GraphQuery,
    *,
    all_scenes: bool = False,
    config: QueryConfig = DEFAULT_CONFIG,
) -> dict[str, QueryResult]:
    """``program``'s result on each of ``scene_ids`` (stored scenes), in one transaction.

    ``all_scenes`` says that ``scene_ids`` are all the stored scenes, so the statement
    needs no scene filter. Raises :class:`~queries.QueryExecutionError` when the database
    fails.
    """
    if not scene_ids:
        return {}
    try:
        with engine.connect() as conn, conn.begin():
            scope = None if all_scenes else list(scene_ids)
            return _ManyRun(conn, scene_ids, scope, config).run(program)
    except sa.exc.DBAPIError as exc:
        reason = str(exc.orig).strip().splitlines()[0] if exc.orig else str(exc)
        raise QueryExecutionError(
            f"the database could not run the program on {len(scene_ids)} scenes: {reason}"
        ) from exc


class _ManyRun:
    def __init__(
        self,
        conn: Connection,
        scene_ids: Sequence[str],
        scope: Sequence[str] | None,
        config: QueryConfig,
    ) -> None:
        self.conn = conn
        self.scene_ids = list(scene_ids)
        self.config = config
        self.c = SqlManySteps(conn, scope, config)
        self.ctes: list[Any] = []
        self.paths: dict[str, list[SupportPath]] = defaultdict(list)

    def run(self, program: GraphQuery) -> dict[str, QueryResult]:
        for i, step in enumerate(program.steps):
            self.ctes.append(self._compile(i, step))
        values = self._fetch(program)
        return {
            sid: QueryResult(
                scene_id=sid,
                program=program,
                answer=values[sid][program.answer_step],
                steps=values[sid],
                support_paths=tuple(sorted(self.paths.get(sid, ()))),
                executor=EXECUTOR_NAME,
            )
            for sid in self.scene_ids
        }

    def _compile(self, i: int, step: Step) -> Any:
        c, name = self.c, f"s{i}"
        src = [(j, self.ctes[j]) for j in step.inputs]
        op = step.op
        if op is Op.SCENE:
            c.whole.add(i)
            return c.scene().cte(name)
        shared = compile_shared(c, name, step, src)
        if shared is not None:
            return shared
        if op is Op.FALL_IF_REMOVED:
            return c.fallen(self._fall(i, src[0][1]), f"fallen{i}").cte(name)
        # count / exists: computed in the final statement from their input's CTE
        return src[0][1]

    def _fall(self, i: int, removed_cte: Any) -> set[Pair]:
        """The fixpoint of every scene with something removed; records the support paths.

        Two statements whatever the number of scenes and rounds: the removed entities, then
        every support edge ``(scene, upper, lower)`` of the scenes they are in with the
        upper entity's category. The rounds are then worked out per scene by the reference
        rule (:func:`queries.semantics.fall_rounds`), which gives each entity the round the
        per-scene executor's statements find it in (see :mod:`queries.sql_executor`).
        """
        removed_rows = sa.select(removed_cte.c.scene_id, removed_cte.c.id)
        removed: dict[str, set[int]] = defaultdict(set)
        for sid, x in raw_rows(self.conn, removed_rows):
            removed[sid].add(x)
        if not removed:
            return set()
        supporters: dict[str, dict[int, list[int]]] = defaultdict(lambda: defaultdict(list))
        structural: dict[str, set[int]] = defaultdict(set)
        for sid, upper, lower, category in raw_rows(self.conn, self.c.support_edges(removed)):
            supporters[sid][upper].append(lower)
            if self.config.is_structural(category):
                structural[sid].add(upper)
        fallen: set[Pair] = set()
        for sid, gone in removed.items():
            rounds = fall_rounds(gone, supporters[sid], structural[sid])
            if rounds:
                self.paths[sid].extend(support_paths(i, gone, rounds, supporters[sid]))
                fallen.update((sid, x) for x in rounds)
        return fallen

    def _fetch(self, program: GraphQuery) -> dict[str, tuple[StepValue, ...]]:
        """Every step's value per scene: one statement for the steps that are not the whole
        scene (their ``(step, scene_id, id)`` rows), one for the scenes' entities when a
        step is the whole scene."""
        parts = []
        chosen = self.c.selected_scenes().subquery("chosen")
        for i, (step, cte) in enumerate(zip(program.steps, self.ctes, strict=True)):
            tag = sa.literal(i, sa.Integer()).label("step")
            if step.op is Op.SCENE:
                continue
            if step.op in (Op.COUNT, Op.EXISTS):
                joined = chosen.outerjoin(cte, cte.c.scene_id == chosen.c.id)
                count = sa.func.count(sa.distinct(cte.c.id))
                parts.append(
                    sa.select(tag, chosen.c.id.label("scene_id"), count.label("id"))
                    .select_from(joined)
                    .group_by(chosen.c.id)
                )
            else:
                parts.append(sa.select(tag, cte.c.scene_id, cte.c.id.label("id")))
        sets: dict[tuple[int, str], set[int]] = defaultdict(set)
        if parts:
            for step_index, sid, value in raw_rows(self.conn, sa.union_all(*parts)):
                sets[step_index, sid].add(value)
        whole: dict[str, list[int]] = defaultdict(list)
        if self.c.whole:
            for sid, x in raw_rows(self.conn, self.c.scene()):
                whole[sid].append(x)
        out: dict[str, tuple[StepValue, ...]] = {}
        for sid in self.scene_ids:
            values: list[StepValue] = []
            for i, step in enumerate(program.steps):
                if step.op is Op.SCENE:
                    values.append(tuple(sorted(whole.get(sid, ()))))
                elif step.op is Op.COUNT:
                    values.append(int(next(iter(sets.get((i, sid), {0})))))
                elif step.op is Op.EXISTS:
                    values.append(bool(next(iter(sets.get((i, sid), {0})))))
                else:
                    values.append(tuple(sorted(sets.get((i, sid), ()))))
            out[sid] = tuple(values)
        return out
