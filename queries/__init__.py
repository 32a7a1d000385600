"""queries: the structured graph-query language (DESIGN §6) and its executors.

* :class:`GraphQuery` / :class:`Step`: the wire format (pydantic), with
  :meth:`GraphQuery.json_schema` (flat, for constrained decoding), the text form
  (:meth:`GraphQuery.to_text` / :meth:`GraphQuery.from_text`) and validation that raises
  :class:`QueryValidationError` naming the step and the field.
* :func:`run_program` / :func:`make_executor`: run a program on a stored scene with the
  ``networkx`` reference, ``sql`` (SQLite / PostgreSQL) or ``sparql`` (Oxigraph / rdflib)
  executor; all three return equal :class:`QueryResult` objects.
* :func:`run_program_all`: one program on many stored scenes (all, a glob or a list),
  one :class:`MultiSceneResult` mapping each scene id to its result; the SQL executor
  answers every scene with one statement.
* :mod:`queries.semantics`: the one definition of what every op and relation means.

Imports :mod:`graph_store` only; never imports torch.
"""

from queries._base import Executor
from queries.api import EXECUTORS, make_executor, run_program
from queries.errors import QueryError, QueryExecutionError, QueryValidationError
from queries.model import OP_SPECS, GraphQuery, Metric, Op, OpSpec, QueryType, Step, Viewpoint
from queries.multi_scene import MultiSceneResult, run_program_all, select_scene_ids
from queries.result import QueryResult, StepValue
from queries.semantics import DEFAULT_CONFIG, QueryConfig, SupportPath

__all__ = [
    "DEFAULT_CONFIG",
    "EXECUTORS",
    "OP_SPECS",
    "Executor",
    "GraphQuery",
    "Metric",
    "MultiSceneResult",
    "Op",
    "OpSpec",
    "QueryConfig",
    "QueryError",
    "QueryExecutionError",
    "QueryResult",
    "QueryType",
    "QueryValidationError",
    "Step",
    "StepValue",
    "SupportPath",
    "Viewpoint",
    "make_executor",
    "run_program",
    "run_program_all",
    "select_scene_ids",
]
