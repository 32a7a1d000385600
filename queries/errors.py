"""The error tree of :mod:`queries`.

:class:`QueryError` is the root; callers (the CLI, the reasoner) catch it and show its
message. Invalid programs raise :class:`QueryValidationError`, which says which step and
which field are at fault.
"""

from __future__ import annotations


class QueryError(Exception):
    """Root of every error raised by :mod:`queries`."""


class QueryValidationError(QueryError):
    """A program (JSON, dict or text form) is not a valid :class:`~queries.GraphQuery`.

    Attributes:
        step: index of the offending step, or ``None`` for a program-level problem.
        field: name of the offending field (``"inputs"``, ``"relation"``, ``"answer_step"``,
            ``"text"`` for the text form...), or ``None``.

    The message starts with ``step N: field 'F': `` when both are known, so it can be fed
    back to a language model as is.

    Deliberately not a :class:`ValueError`: pydantic would otherwise swallow it into its
    own error type.
    """

    def __init__(self, message: str, *, step: int | None = None, field: str | None = None):
        where = []
        if step is not None:
            where.append(f"step {step}")
        if field is not None:
            where.append(f"field {field!r}")
        full = f"{': '.join(where)}: {message}" if where else message
        super().__init__(full)
        self.step = step
        self.field = field
        self.reason = message


class QueryExecutionError(QueryError):
    """A valid program could not be run: unknown executor, unusable backend, timeout."""
