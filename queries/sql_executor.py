"""The SQL executor: a program compiled to SQLAlchemy Core over the store's tables.

Each step is one CTE (``s0``, ``s1``, ...) of a single ``WITH`` statement whose final
``SELECT`` returns every step's rows (``UNION ALL`` of ``(step, id)``), so the database
computes every intermediate set (the ids of the whole scene, when a step is ``scene()``,
come from one plain ``SELECT`` beside it, read again only when the scene row shows the
scene was saved again since the executor last read them); ``support_closure`` is a
recursive CTE. A CTE may list an id twice (``relate`` unions both edge directions without
de-duplicating); every reader treats CTEs as sets (``IN``, ``count(DISTINCT)``, a Python
set at the end). Two things run as
several statements, combined in Python with the shared rules of :mod:`queries.semantics`:
the distinct strings that text filters match against (read first, matched in Python, bound
back), and ``fall_if_removed``, an iterative fixpoint with one SQL statement per round
(and one to read the supporters that explain each fallen entity); its result then enters the
main statement as an inline id list. Works on SQLite and PostgreSQL.

PostgreSQL, unlike IEEE-754, raises on floating-point underflow (a product below about
1e-308, i.e. coordinates closer than about 1e-154 scene units); such a run, like any other
database failure, raises :class:`~queries.QueryExecutionError`.
"""

from __future__ import annotations

from collections import defaultdict
from operator import itemgetter
from typing import Any

import sqlalchemy as sa
from sqlalchemy.engine import Connection, Engine

from graph_store import models as m
from graph_store.errors import SceneNotFound
from queries._base import Executor
from queries._sql_steps import E, SqlSteps, compile_shared, ids_literal
from queries.errors import QueryExecutionError
from queries.model import GraphQuery, Op, Step
from queries.result import QueryResult, StepValue
from queries.semantics import DEFAULT_CONFIG, QueryConfig, SupportPath, support_paths

#: Compiled programs an executor keeps (the oldest is dropped first).
PREPARED = 64


class SqlExecutor(Executor):
    """Runs programs with SQL on a store database (SQLite or PostgreSQL).

    Args:
        engine: a SQLAlchemy engine on a store (``open_store(url).engine``).
        scene_id: the stored scene to query; :class:`SceneNotFound` when absent.
    """

    name = "sql"

    def __init__(self, engine: Engine, scene_id: str, config: QueryConfig = DEFAULT_CONFIG):
        super().__init__(scene_id, config)
        self.engine = engine
        #: The scene's ids in order, with the scene row's version they were read under.
        self._scene_ids: tuple[Any, tuple[int, ...]] | None = None
        #: Programs already compiled, by program and scene version: their final statement
        #: and the steps that are the whole scene (at most :data:`PREPARED` kept).
        self._prepared: dict[tuple[GraphQuery, tuple[Any, ...]], tuple[Any, set[int]]] = {}
        with engine.connect() as conn:
            found = conn.execute(sa.select(m.scenes.c.id).where(m.scenes.c.id == scene_id)).first()
        if found is None:
            raise SceneNotFound(f"no scene {scene_id!r} in the store at {engine.url!r}")

    def _execute(self, program: GraphQuery) -> QueryResult:
        try:
            with self.engine.connect() as conn, conn.begin():
                s = m.scenes.c
                version = conn.execute(
                    sa.select(s.created_at, s.entity_count).where(s.id == self.scene_id)
                ).first()
                if version is None:  # deleted since this executor was made
                    raise SceneNotFound(f"no scene {self.scene_id!r} in the store")
                return _SqlRun(conn, self.scene_id, self.config, self, tuple(version)).run(program)
        except sa.exc.DBAPIError as exc:
            reason = str(exc.orig).strip().splitlines()[0] if exc.orig else str(exc)
            raise QueryExecutionError(
                f"the database could not run the program on scene {self.scene_id!r}: {reason}"
            ) from exc

    def scene_ids(self, conn: Connection, c: SqlSteps, version: tuple[Any, ...]) -> tuple[int, ...]:
        """The scene's entity ids, ascending, read again only when the scene changed.

        A stored scene's entities change only when the whole scene is saved again or
        deleted, which writes a new scene row; its ``version`` (``created_at`` and
        ``entity_count``, read in the run's own transaction) tells whether the ids read
        before still hold.
        """
        cached = self._scene_ids
        if cached is not None and cached[0] == version:
            return cached[1]
        ids = tuple(map(itemgetter(0), raw_rows(conn, c.scene().order_by(E.c.id))))
        self._scene_ids = (version, ids)
        return ids


class _SqlRun:
    def __init__(
        self,
        conn: Connection,
        scene_id: str,
        config: QueryConfig,
        owner: SqlExecutor,
        version: tuple[Any, ...],
    ) -> None:
        self.owner = owner
        self.version = version
        self.conn = conn
        self.scene_id = scene_id
        self.config = config
        self.c = SqlSteps(conn, scene_id, config)
        self.ctes: list[Any] = []
        self.paths: list[SupportPath] = []

    def run(self, program: GraphQuery) -> QueryResult:
        prepared = self.owner._prepared
        key = (program, self.version)
        if key in prepared:
            statement, self.c.whole = prepared[key]
        else:
            for i, step in enumerate(program.steps):
                self.ctes.append(self._compile(i, step))
            statement = self._statement(program)
            # a fixpoint's rounds and their support paths are read anew each run
            if all(step.op is not Op.FALL_IF_REMOVED for step in program.steps):
                if len(prepared) >= PREPARED:
                    del prepared[next(iter(prepared))]
                prepared[key] = (statement, set(self.c.whole))
        values = self._fetch(program, statement)
        return QueryResult(
            scene_id=self.scene_id,
            program=program,
            answer=values[program.answer_step],
            steps=values,
            support_paths=tuple(sorted(self.paths)),
            executor=SqlExecutor.name,
        )

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
            fallen = self._fall(i, src[0][1])
            return (
                sa.select(E.c.id)
                .where(E.c.scene_id == self.scene_id, E.c.id.in_(ids_literal(fallen, f"fallen{i}")))
                .cte(name)
            )
        # count / exists: computed in the final statement from their input's CTE
        return src[0][1]

    def _fall(self, i: int, removed_cte: Any) -> set[int]:
        """The fixpoint, one statement per round; records the support paths.

        Round ``r`` looks only at what rests on the entities added in round ``r - 1``
        (an entity whose supporters were all known earlier fell earlier), keeps those not
        known yet, not structural, and with no supporter outside the known set.
        """
        removed = {r[0] for r in raw_rows(self.conn, sa.select(removed_cte.c.id))}
        structural = [cat for cat in self.c.categories() if self.config.is_structural(cat)]
        rounds: dict[int, int] = {}
        known, frontier = set(removed), set(removed)
        current = 0
        while frontier:
            current += 1
            known_ids = ids_literal(known, "known")
            cand = self.c.resting_on(ids_literal(frontier, "frontier")).subquery("cand")
            query = (
                sa.select(cand.c.id)
                .join(E, sa.and_(E.c.scene_id == self.scene_id, E.c.id == cand.c.id))
                .where(cand.c.id.not_in(known_ids), E.c.category.not_in(structural))
                .where(~self.c.held_outside(cand.c.id, known_ids))
            )
            frontier = {r[0] for r in raw_rows(self.conn, query)}
            rounds.update((x, current) for x in frontier)
            known |= frontier
        if rounds:
            supporters: dict[int, list[int]] = defaultdict(list)
            edges = self.c.supporter_edges(ids_literal(set(rounds), "fallen"))
            for upper, lower in raw_rows(self.conn, edges):
                supporters[upper].append(lower)
            self.paths.extend(support_paths(i, removed, rounds, supporters))
        return set(rounds)

    def _statement(self, program: GraphQuery) -> Any:
        """The one statement for the steps that are not the whole scene (their ``(step,
        id)`` rows), or ``None`` when every step is."""
        parts = []
        for i, (step, cte) in enumerate(zip(program.steps, self.ctes, strict=True)):
            tag = sa.literal(i, sa.Integer()).label("step")
            if step.op is Op.SCENE:
                continue
            if step.op is Op.COUNT:
                count = sa.func.count(sa.distinct(cte.c.id)).label("id")
                parts.append(sa.select(tag, count))
            elif step.op is Op.EXISTS:
                flag = sa.case((sa.exists(sa.select(cte.c.id)), 1), else_=0)
                parts.append(sa.select(tag, flag.label("id")))
            else:
                parts.append(sa.select(tag, cte.c.id.label("id")))
        return sa.union_all(*parts) if parts else None

    def _fetch(self, program: GraphQuery, statement: Any) -> tuple[StepValue, ...]:
        """Every step's value: ``statement``'s rows, and the scene's ids when a step is
        the scene."""
        sets: dict[int, set[int]] = defaultdict(set)
        if statement is not None:
            for step_index, value in raw_rows(self.conn, statement):
                sets[step_index].add(value)
        scene: tuple[int, ...] = ()
        if self.c.whole:
            scene = self.owner.scene_ids(self.conn, self.c, self.version)
        out: list[StepValue] = []
        for i, step in enumerate(program.steps):
            if step.op is Op.SCENE:
                out.append(scene)
            elif step.op is Op.COUNT:
                out.append(int(next(iter(sets[i]))))
            elif step.op is Op.EXISTS:
                out.append(bool(next(iter(sets[i]))))
            else:
                out.append(tuple(sorted(sets[i])))
        return tuple(out)


def raw_rows(conn: Connection, statement: Any) -> list[Any]:
    """All rows of ``statement`` as the driver returns them (integers and strings need no
    conversion, and skipping SQLAlchemy's per-row processing is several times faster)."""
    result = conn.execute(statement)
    try:
        rows: list[Any] = list(result.cursor.fetchall())
    finally:
        result.close()
    return rows
