"""The error tree of :mod:`graph_store`.

Every error the store raises on bad input or a bad environment derives from
:class:`GraphStoreError`; callers can catch the root and print its message.
"""

from __future__ import annotations


class GraphStoreError(Exception):
    """Root of every error raised by :mod:`graph_store`."""


class InvalidSceneError(GraphStoreError, ValueError):
    """A scene graph (or an input that would become one) is malformed.

    Raised for NaN/Inf coordinates, duplicate ids, relations that point at missing
    entities, unknown relation names, and similar problems. Nothing is written.
    """


class SceneNotFound(GraphStoreError, KeyError):
    """No scene with the given id is stored."""

    def __str__(self) -> str:  # KeyError would repr() the message
        return str(self.args[0]) if self.args else "scene not found"


class SceneExistsError(GraphStoreError):
    """``save_scene(..., if_exists="fail")`` found a scene with the same id."""


class EntityNotFound(GraphStoreError, KeyError):
    """``get_entity`` found no entity with the given id in the scene."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else "entity not found"


class StoreConnectionError(GraphStoreError):
    """The database URL is malformed, or the database cannot be reached or opened."""


class StoreNotFoundError(StoreConnectionError):
    """A read-only open found no store: the SQLite file does not exist (none is created)."""


class SchemaVersionError(GraphStoreError):
    """The database schema is not at the revision this code expects.

    The message says which command brings it up to date (``causalsplat db upgrade``).
    """


class RDFFormatError(GraphStoreError):
    """An RDF document cannot be parsed, or does not describe a valid scene."""


class SparqlError(GraphStoreError):
    """Root of the SPARQL errors."""


class SparqlArgumentError(SparqlError, ValueError):
    """An argument of a SPARQL call is out of range (a limit, a timeout, a binding that
    names no variable of the query); the message gives the allowed range."""


class SparqlSyntaxError(SparqlError, ValueError):
    """The SPARQL text does not parse as a query."""


class SparqlForbiddenError(SparqlError):
    """The SPARQL text asks for something the read-only endpoint refuses.

    Updates (``INSERT``/``DELETE``/``LOAD``/``CLEAR``/...), ``SERVICE`` clauses and
    dataset clauses (``FROM``/``FROM NAMED``, which would fetch remote graphs).
    """


class SparqlTimeoutError(SparqlError, TimeoutError):
    """The query did not finish within its time limit."""


class SparqlResourceError(SparqlTimeoutError):
    """The query's worker process ran out of its memory limit (and was stopped)."""


class SparqlFormatError(SparqlError, ValueError):
    """A SPARQL result cannot be written in the format asked: a format of the other kind
    of result (CSV for a graph, Turtle for a table), or text that XML 1.0 cannot hold."""


class SparqlRowLimitError(SparqlError):
    """The query produced more rows than the caller's row limit (``on_limit="error"``)."""
