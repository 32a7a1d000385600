"""Questions across scenes: one program run on many stored scenes, answers per scene.

>>> store = open_store("sqlite:///scannet.db")                           # doctest: +SKIP
>>> results = run_program_all(store, program, scenes="scene00*")         # doctest: +SKIP
>>> [r.scene_id for r in results.answered()]                             # doctest: +SKIP
['scene0002_00', 'scene0007_00']

Scenes are chosen with ``scenes``: ``None`` for every stored scene, a glob (``"scene00*"``,
``fnmatch`` rules, case-sensitive) or a list of scene ids. How each executor runs:

* ``"sql"``: one statement for all selected scenes (:mod:`queries.sql_many`), the database
  doing the work once; ``fall_if_removed`` one statement per round for all of them;
* ``"sparql"``: one Oxigraph (or rdflib) dataset holding every selected scene, loaded
  once, and one query per step for all of them (:mod:`queries.sparql_many`);
  ``fall_if_removed`` one query per round for all of them;
* ``"networkx"``: the reference, scene after scene in memory.

Every scene's :class:`~queries.QueryResult` is the one :func:`~queries.run_program` gives
on that scene alone (answer, step values and support paths).
"""

from __future__ import annotations

import fnmatch
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import sqlalchemy as sa

from graph_store.errors import SceneNotFound
from queries.api import ExecutorName, _store, make_executor
from queries.errors import QueryExecutionError
from queries.model import GraphQuery
from queries.result import QueryResult, StepValue
from queries.semantics import DEFAULT_CONFIG, QueryConfig

if TYPE_CHECKING:
    from graph_store.repository import GraphStore
    from queries.sparql_endpoints import SparqlBackendName

#: Which scenes: ``None`` (all stored), a glob, or scene ids.
SceneSelection = str | Sequence[str] | None
_GLOB_CHARS = frozenset("*?[")


def is_glob(text: str) -> bool:
    """Whether ``text`` is a pattern (has ``*``, ``?`` or ``[``) rather than one scene id.

    >>> is_glob("scene00*"), is_glob("scene0000_00")
    (True, False)
    """
    return any(ch in _GLOB_CHARS for ch in text)


def select_scene_ids(store: GraphStore, scenes: SceneSelection = None) -> tuple[str, ...]:
    """The stored scene ids ``scenes`` selects, sorted.

    Raises :class:`graph_store.SceneNotFound` when a glob matches no stored scene or a
    listed id is not stored. ``None`` on an empty store selects nothing (no error).
    """
    return _select(_stored_ids(store), scenes, store.url)


def _stored_ids(store: GraphStore) -> list[str]:
    from graph_store import models as m

    with store.engine.connect() as conn:
        return list(conn.execute(sa.select(m.scenes.c.id).order_by(m.scenes.c.id)).scalars())


def _select(stored: list[str], scenes: SceneSelection, url: str) -> tuple[str, ...]:
    if scenes is None:
        return tuple(stored)
    if isinstance(scenes, str) and is_glob(scenes):
        chosen = [sid for sid in stored if fnmatch.fnmatchcase(sid, scenes)]
        if not chosen:
            raise SceneNotFound(f"no stored scene matches {scenes!r} ({len(stored)} stored)")
        return tuple(chosen)
    wanted = [scenes] if isinstance(scenes, str) else list(scenes)
    known = set(stored)
    for sid in wanted:
        if sid not in known:
            raise SceneNotFound(f"no scene {sid!r} in the store at {url}")
    return tuple(sorted(set(wanted)))


@dataclass(frozen=True, slots=True)
class MultiSceneResult(Mapping[str, QueryResult]):
    """One program's results on many scenes: a read-only mapping scene id -> result.

    Iterates in scene-id order and keeps the scenes whose answer is empty (an empty set,
    a count of 0, ``False``); :meth:`answered` leaves them out.

    Attributes:
        program: the program that ran.
        results: one :class:`~queries.QueryResult` per selected scene, sorted by scene id.
        executor: the executor that produced them; not part of equality.
    """

    program: GraphQuery
    results: tuple[QueryResult, ...]
    executor: str = field(default="", compare=False)
    _index: dict[str, int] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        ids = [r.scene_id for r in self.results]
        if ids != sorted(set(ids)):
            raise ValueError("results must be sorted by scene id, one per scene")
        object.__setattr__(self, "_index", {sid: i for i, sid in enumerate(ids)})

    def __getitem__(self, scene_id: str) -> QueryResult:
        return self.results[self._index[scene_id]]

    def __iter__(self) -> Iterator[str]:
        return (r.scene_id for r in self.results)

    def __len__(self) -> int:
        return len(self.results)

    @property
    def scene_ids(self) -> tuple[str, ...]:
        return tuple(r.scene_id for r in self.results)

    def answered(self) -> tuple[QueryResult, ...]:
        """The results whose answer is not empty (entities found, a count above 0, yes)."""
        return tuple(r for r in self.results if has_answer(r.answer))

    def answers(self) -> dict[str, StepValue]:
        """Every scene's answer, by scene id."""
        return {r.scene_id: r.answer for r in self.results}

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready document: the program, counts and every scene's result."""
        return {
            "program": self.program.to_dict(),
            "executor": self.executor,
            "scenes": len(self.results),
            "answered": len(self.answered()),
            "results": [r.to_dict() for r in self.results],
        }


def has_answer(answer: StepValue) -> bool:
    """Whether an answer is non-empty: entities, a count above 0, or ``True``.

    >>> has_answer(()), has_answer((3,)), has_answer(0), has_answer(True)
    (False, True, False, True)
    """
    return bool(answer)


def run_program_all(
    source: Any,
    program: GraphQuery | str | bytes | dict[str, Any],
    *,
    scenes: SceneSelection = None,
    executor: ExecutorName | str = "sql",
    config: QueryConfig = DEFAULT_CONFIG,
    sparql_backend: SparqlBackendName = "oxigraph",
) -> MultiSceneResult:
    """Validate ``program`` and run it on every scene ``scenes`` selects (see the module).

    ``source`` is a :class:`graph_store.GraphStore` or an engine on one. Raises
    :class:`~queries.QueryValidationError` for an invalid program,
    :class:`graph_store.SceneNotFound` for a selection that names no stored scene and
    :class:`~queries.QueryExecutionError` for an unknown executor; nothing is written.
    """
    query = GraphQuery.parse(program)
    store = _store(source)
    if executor not in ("networkx", "sql", "sparql"):
        raise QueryExecutionError(
            f"unknown executor {executor!r}; expected one of: networkx, sql, sparql"
        )
    stored = _stored_ids(store)
    ids = _select(stored, scenes, store.url)
    by_scene: dict[str, QueryResult]
    if executor == "sql":
        from queries.sql_many import run_sql_many

        # a selection of every stored scene needs no scene filter in the statement
        every = len(ids) == len(stored)
        by_scene = run_sql_many(store.engine, ids, query, all_scenes=every, config=config)
    elif executor == "sparql":
        by_scene = _sparql_many(store, ids, query, config, sparql_backend)
    else:
        by_scene = {
            sid: make_executor(store, sid, executor="networkx", config=config).run(query)
            for sid in ids
        }
    return MultiSceneResult(query, tuple(by_scene[sid] for sid in ids), str(executor))


def _sparql_many(
    store: GraphStore,
    ids: Sequence[str],
    query: GraphQuery,
    config: QueryConfig,
    backend: SparqlBackendName,
) -> dict[str, QueryResult]:
    """One dataset holding every selected scene, one query per step for all of them."""
    from queries.sparql_endpoints import endpoint_for
    from queries.sparql_many import run_sparql_many

    if not ids:
        return {}
    endpoint = endpoint_for([store.load_scene(sid) for sid in ids], backend)
    return run_sparql_many(endpoint, ids, query, config, all_scenes=True)
