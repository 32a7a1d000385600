r"""The text form of a program, for logs and prompts; it reads back to the same program.

Grammar (one statement per line; blank lines and ``#`` comments are ignored)::

    program   := "query" TYPE  step*  ["return" REF]
    step      := REF "=" OP "(" [arg ("," arg)*] ")"
    arg       := REF                          -- an input; inputs come first, in order
               | STRING                       -- value
               | NAME                         -- relation (relate), metric (argmin/argmax/middle)
               | "k" "=" INT
               | "value" "=" STRING | "relation" "=" NAME | "metric" "=" NAME
               | "viewpoint" "=" "(" NUM "," NUM "," NUM ")" "->" "(" NUM "," NUM "," NUM ")"
    REF       := "v" INT                      -- step N is written vN, and steps are numbered
                                                 in order from v0
    STRING    := a JSON string literal: "..." with \" \\ \n \t \r \b \f \/ \uXXXX escapes
    NUM       := a decimal number as Python's repr(float) writes it (1.0, -2.5e-07)

``return vN`` names the answer step (default: the last step). Example::

    query spatial
    v0 = scene()
    v1 = filter_category(v0, "sink")
    v2 = filter_category(v0, "towel")
    v3 = relate(v2, v1, left_of, viewpoint=(0.0, 0.0, 1.5)->(2.0, 1.0, 0.8))
    v4 = argmin(v3, v1, distance, k=2)
    return v4

:func:`format_text` writes this canonical form (inputs, then value, relation, metric,
``k=``, ``viewpoint=``; floats with ``repr``; strings as JSON with every control and
line-separator character escaped), and ``parse_text(format_text(q)) == q`` for every
program ``q``.
"""

from __future__ import annotations

import json
import re
from typing import TYPE_CHECKING, Any, NoReturn

from graph_store.types import RelationType
from queries.errors import QueryValidationError

if TYPE_CHECKING:
    from queries.model import GraphQuery, Viewpoint

_TOKEN = re.compile(
    r"""
    (?P<ws>[ \t]+)
    |(?P<comment>\#.*)
    |(?P<string>"(?:[^"\\\n]|\\.)*")
    |(?P<arrow>->)
    |(?P<number>[-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?)
    |(?P<name>[A-Za-z_][A-Za-z0-9_]*)
    |(?P<punct>[=(),])
    """,
    re.VERBOSE,
)
_REF = re.compile(r"v(0|[1-9][0-9]*)")
_INT = re.compile(r"[-+]?\d+")
_EXTRA_ESCAPES = {"\x7f": "\\u007f", "\x85": "\\u0085", "\u2028": "\\u2028", "\u2029": "\\u2029"}
_RELATIONS = {r.value for r in RelationType}


def quote(text: str) -> str:
    """``text`` as a JSON string literal with no raw control or line-separator character."""
    out = json.dumps(text, ensure_ascii=False)
    for raw, escaped in _EXTRA_ESCAPES.items():
        out = out.replace(raw, escaped)
    return out


def _viewpoint(vp: Viewpoint) -> str:
    eye = ", ".join(repr(float(c)) for c in vp.eye)
    target = ", ".join(repr(float(c)) for c in vp.target)
    return f"({eye})->({target})"


def format_text(program: GraphQuery) -> str:
    """The canonical text form of ``program`` (lines joined by ``\\n``, no final newline)."""
    lines = [f"query {program.query_type.value}"]
    for i, s in enumerate(program.steps):
        args = [f"v{j}" for j in s.inputs]
        if s.value is not None:
            args.append(quote(s.value))
        if s.relation is not None:
            args.append(s.relation.value)
        if s.metric is not None:
            args.append(s.metric.value)
        if s.k is not None:
            args.append(f"k={s.k}")
        if s.viewpoint is not None:
            args.append(f"viewpoint={_viewpoint(s.viewpoint)}")
        lines.append(f"v{i} = {s.op.value}({', '.join(args)})")
    lines.append(f"return v{program.answer_step}")
    return "\n".join(lines)


class _Line:
    """The tokens of one line, with a cursor."""

    def __init__(self, text: str, number: int, step: int | None) -> None:
        self.lineno, self.step = number, step
        self.tokens: list[tuple[str, str, int]] = []
        pos = 0
        while pos < len(text):
            m = _TOKEN.match(text, pos)
            if m is None:
                self.fail(f"unexpected character {text[pos]!r}", pos)
            kind = m.lastgroup or ""
            if kind not in ("ws", "comment"):
                self.tokens.append((kind, m.group(), pos))
            pos = m.end()
        self.i = 0

    def fail(self, message: str, column: int | None = None) -> NoReturn:
        if column is None:
            column = self.tokens[self.i][2] if self.i < len(self.tokens) else -1
        where = f"line {self.lineno}" + (f", column {column + 1}" if column >= 0 else ", at end")
        raise QueryValidationError(f"{where}: {message}", step=self.step, field="text")

    def peek(self) -> tuple[str, str]:
        if self.i < len(self.tokens):
            kind, text, _ = self.tokens[self.i]
            return kind, text
        return "end", ""

    def take(self, kind: str, text: str | None = None) -> str:
        k, t = self.peek()
        if k != kind or (text is not None and t != text):
            want = repr(text) if text is not None else f"a {kind}"
            self.fail(f"expected {want}, found {t!r}" if k != "end" else f"expected {want}")
        self.i += 1
        return t

    def done(self) -> None:
        if self.i < len(self.tokens):
            self.fail(f"unexpected {self.tokens[self.i][1]!r}")

    def ref(self) -> int:
        name = self.take("name")
        m = _REF.fullmatch(name)
        if m is None:
            self.i -= 1
            self.fail(f"expected a step reference like v0, found {name!r}")
        return int(m.group(1))

    def string(self) -> str:
        raw = self.take("string")
        try:
            value = json.loads(raw)
        except ValueError as exc:
            self.i -= 1
            self.fail(f"bad string literal {raw}: {exc}")
        assert isinstance(value, str)
        return value

    def number(self) -> float:
        return float(self.take("number"))

    def xyz(self) -> list[float]:
        self.take("punct", "(")
        out = [self.number()]
        for _ in range(2):
            self.take("punct", ",")
            out.append(self.number())
        self.take("punct", ")")
        return out


def _keyword(line: _Line, name: str, step: dict[str, Any]) -> None:
    if name in step:
        line.fail(f"{name} is given twice")
    if name == "k":
        raw = line.take("number")
        if _INT.fullmatch(raw) is None:
            line.i -= 1
            line.fail(f"k must be an integer, found {raw!r}")
        step["k"] = int(raw)
    elif name == "value":
        step["value"] = line.string()
    elif name in ("relation", "metric"):
        step[name] = line.take("name")
    elif name == "viewpoint":
        eye = line.xyz()
        line.take("arrow")
        step["viewpoint"] = {"eye": eye, "target": line.xyz()}
    else:
        line.i -= 2
        line.fail(f"unknown keyword {name!r} (expected k, value, relation, metric, viewpoint)")


def _argument(line: _Line, step: dict[str, Any]) -> None:
    kind, text = line.peek()
    if kind == "name" and _REF.fullmatch(text):
        if len(step) > 2:
            line.fail("step references (inputs) must come before the other arguments")
        step["inputs"].append(line.ref())
    elif kind == "string":
        if "value" in step:
            line.fail("value is given twice")
        step["value"] = line.string()
    elif kind == "name":
        line.take("name")
        if line.peek() == ("punct", "="):
            line.take("punct", "=")
            _keyword(line, text, step)
            return
        field = "relation" if text in _RELATIONS else "metric"
        if field in step:
            line.i -= 1
            line.fail(f"{field} is given twice")
        step[field] = text
    else:
        line.fail(f"expected an argument, found {text!r}" if kind != "end" else "expected ')'")


def _step(line: _Line, index: int) -> dict[str, Any]:
    if line.ref() != index:
        line.i -= 1
        line.fail(f"expected v{index} (steps are numbered in order from v0)")
    line.take("punct", "=")
    step: dict[str, Any] = {"op": line.take("name"), "inputs": []}
    line.take("punct", "(")
    if line.peek() != ("punct", ")"):
        _argument(line, step)
        while line.peek() == ("punct", ","):
            line.take("punct", ",")
            _argument(line, step)
    line.take("punct", ")")
    line.done()
    return step


def parse_text(text: str) -> GraphQuery:
    """Read the text form back into a validated :class:`~queries.GraphQuery`."""
    from queries.model import GraphQuery

    if not isinstance(text, str):
        raise QueryValidationError(f"the text form must be a string, not {type(text).__name__}")
    query_type: str | None = None
    answer: int | None = None
    steps: list[dict[str, Any]] = []
    for number, raw in enumerate(text.split("\n"), start=1):
        line = _Line(raw.removesuffix("\r"), number, len(steps))
        kind, word = line.peek()
        if kind == "end":
            continue
        if kind == "name" and word == "query":
            if query_type is not None or steps:
                line.fail("'query TYPE' must be the first statement, once")
            line.take("name")
            query_type = line.take("name")
            line.done()
        elif kind == "name" and word == "return":
            if answer is not None:
                line.fail("'return' is given twice")
            line.take("name")
            answer = line.ref()
            line.done()
        else:
            if query_type is None:
                line.fail("the program must start with 'query TYPE' (e.g. 'query spatial')")
            steps.append(_step(line, len(steps)))
    if query_type is None:
        raise QueryValidationError("empty program: expected 'query TYPE' and steps", field="text")
    document = {
        "query_type": query_type,
        "steps": steps,
        "answer_step": answer if answer is not None else max(len(steps) - 1, 0),
    }
    return GraphQuery.model_validate(document)
