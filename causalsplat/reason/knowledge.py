"""The shipped knowledge table: what indoor objects are, what they are for, where they are.

The data file ``data/knowledge.toml`` holds one entry per object category (keyed by the
category name as datasets spell it, lower case): other names for it (``also``), what it is
(``is``), the purposes and needs it serves (``for``), what people do with it
(``affords``), what it holds and the rooms it is found in. Its header comment says how
entries are written. The offline reasoner grounds implicit instructions by comparing them,
with a sentence-embedding model, to :meth:`ObjectFacts.descriptions` of the categories in
the scene. ``data/knowledge.toml`` is the table people edit; the package reads
``data/knowledge.json``, the same document generated from it by
``scripts/make_knowledge_json.py`` (:func:`knowledge_json`; a test fails while the two
differ), because a cold ``ask`` parses JSON about 30 times faster than TOML. The table is
read once per process, on first use, with the standard library.

>>> knowledge = load_knowledge()
>>> knowledge.get("fridge").name
'refrigerator'
>>> "keeping food and drinks cold" in knowledge.get("Refrigerator").uses
True
>>> knowledge.get("fridge").descriptions()[1]
'refrigerator: used for keeping food and drinks cold'
>>> "sofa" in knowledge, knowledge.get("unobtainium")
(True, None)
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any

from causalsplat.reason.errors import ReasonError

FORMAT = "causalsplat-knowledge/1"

#: The longest string the shipped table may hold (a review rule the tests enforce).
MAX_CHARS = 70

_LIST_FIELDS = ("also", "for", "affords", "holds", "found_in")
_FIELDS = ("also", "is", "for", "affords", "holds", "found_in")


def normalize(name: str) -> str:
    """``name`` as the table's keys and lookups compare it: lower case, words separated by
    single spaces, no leading or trailing space."""
    return " ".join(name.lower().split())


@dataclass(frozen=True, slots=True)
class ObjectFacts:
    """The facts of one category of the table.

    Attributes:
        name: the entry's key (lower case, as datasets spell the category).
        also: other names for the same kind of object (synonyms, plurals, misspellings).
        is_a: what it is, a short noun phrase (the TOML ``is``).
        uses: the purposes and needs it serves, gerund phrases (the TOML ``for``).
        affords: what people do with or on it, verb phrases.
        holds: what it typically holds, contains or supports.
        found_in: rooms where it is usually found (``"any room"`` when everywhere).
    """

    name: str
    also: tuple[str, ...]
    is_a: str
    uses: tuple[str, ...]
    affords: tuple[str, ...]
    holds: tuple[str, ...]
    found_in: tuple[str, ...]

    def function_descriptions(self) -> tuple[str, ...]:
        """What it is and what it is for: ``"<name>: <is_a>"``, ``"<name>: used for <use>"``
        for each use and ``"<name>: you can <affordance>"`` for each affordance (the
        sentences the grounding stage scores an instruction against)."""
        n = self.name
        out = [f"{n}: {self.is_a}"]
        out += [f"{n}: used for {u}" for u in self.uses]
        out += [f"{n}: you can {a}" for a in self.affords]
        return tuple(out)

    def descriptions(self) -> tuple[str, ...]:
        """Short sentences to embed, one per fact, each starting ``"<name>: "``, in this
        order: ``"<name>: <is_a>"``; ``"<name>: used for <use>"`` for each use; ``"<name>:
        you can <affordance>"`` for each affordance; ``"<name>: holds <a>, <b>"`` when it
        holds anything; ``"<name>: found in the <room> or the <room>"`` (``"any room"`` is
        written without ``the``) when rooms are listed; ``"<name>: also called <a>, <b>"``
        when it has other names."""
        n = self.name
        out = list(self.function_descriptions())
        if self.holds:
            out.append(f"{n}: holds {', '.join(self.holds)}")
        if self.found_in:
            rooms = [r if r.startswith("any ") else f"the {r}" for r in self.found_in]
            out.append(f"{n}: found in {' or '.join(rooms)}")
        if self.also:
            out.append(f"{n}: also called {', '.join(self.also)}")
        return tuple(out)


class Knowledge:
    """The table's entries, looked up by key or by alias.

    Lookups (:meth:`get`, ``in``) ignore case and extra whitespace; the key wins over the
    aliases, and no alias is claimed by two entries or equals another entry's key (checked
    when the table is built).
    """

    def __init__(self, facts: Iterable[ObjectFacts], source: str = "knowledge table") -> None:
        self._facts: dict[str, ObjectFacts] = {}
        for f in facts:
            if f.name in self._facts:
                raise ReasonError(f"{source}: entry {f.name!r} appears twice")
            self._facts[f.name] = f
        self._alias: dict[str, str] = {}
        for f in self._facts.values():
            for alias in f.also:
                key = normalize(alias)
                if key in self._facts:
                    raise ReasonError(
                        f"{source}: entry {f.name!r}: field 'also': alias {alias!r} "
                        "is itself an entry"
                    )
                other = self._alias.get(key)
                if other is not None:
                    raise ReasonError(
                        f"{source}: entry {f.name!r}: field 'also': alias {alias!r} "
                        f"is already claimed by {other!r}"
                    )
                self._alias[key] = f.name

    def __len__(self) -> int:
        return len(self._facts)

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and self.get(name) is not None

    def __iter__(self) -> Iterator[ObjectFacts]:
        """The entries, in :attr:`names` order."""
        return (self._facts[n] for n in self.names)

    @property
    def names(self) -> tuple[str, ...]:
        """The entry keys, sorted."""
        return tuple(sorted(self._facts))

    def get(self, name: str) -> ObjectFacts | None:
        """The entry whose key, else whose alias, is ``name`` (case and whitespace
        normalised); ``None`` when none is."""
        key = normalize(name)
        hit = self._facts.get(key)
        if hit is not None:
            return hit
        owner = self._alias.get(key)
        return None if owner is None else self._facts[owner]


def _strings(entry: str, field: str, value: Any, source: str) -> tuple[str, ...]:
    where = f"{source}: entry {entry!r}: field {field!r}"
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise ReasonError(f"{where} must be a list of strings, got {value!r}")
    if any(not v.strip() for v in value):
        raise ReasonError(f"{where} holds an empty string")
    return tuple(value)


def _entry(name: str, table: Any, source: str) -> ObjectFacts:
    if not isinstance(table, dict):
        raise ReasonError(f"{source}: top-level key {name!r} must be an entry table")
    if normalize(name) != name:
        raise ReasonError(f"{source}: entry {name!r}: key must be lower case, single-spaced")
    unknown = sorted(set(table) - set(_FIELDS))
    if unknown:
        raise ReasonError(
            f"{source}: entry {name!r}: unknown field {unknown[0]!r} (known: {', '.join(_FIELDS)})"
        )
    is_a = table.get("is")
    if not isinstance(is_a, str) or not is_a.strip():
        raise ReasonError(f"{source}: entry {name!r}: field 'is' must be a non-empty string")
    lists = {f: _strings(name, f, table.get(f, []), source) for f in _LIST_FIELDS}
    if not lists["for"]:
        raise ReasonError(f"{source}: entry {name!r}: field 'for' must not be empty")
    return ObjectFacts(
        name=name,
        also=lists["also"],
        is_a=is_a,
        uses=lists["for"],
        affords=lists["affords"],
        holds=lists["holds"],
        found_in=lists["found_in"],
    )


def parse_knowledge(document: dict[str, Any], source: str = "knowledge table") -> Knowledge:
    """Build and validate a :class:`Knowledge` from a parsed TOML (or JSON) document; raises
    :class:`ReasonError` naming ``source``, the entry and the field on any problem."""
    fmt = document.get("format")
    if fmt != FORMAT:
        raise ReasonError(f"{source}: format {fmt!r}, expected {FORMAT!r}")
    return Knowledge((_entry(k, v, source) for k, v in document.items() if k != "format"), source)


def _parse_toml(text: str, source: str) -> dict[str, Any]:
    import tomllib

    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ReasonError(f"{source}: not valid TOML: {exc}") from None


def _parse_json(text: str, source: str) -> dict[str, Any]:
    try:
        document = json.loads(text)
    except ValueError as exc:
        raise ReasonError(f"{source}: not valid JSON: {exc}") from None
    if not isinstance(document, dict):
        raise ReasonError(f"{source}: the document must be a JSON object")
    return document


def knowledge_json(toml_text: str, source: str = "knowledge.toml") -> str:
    """The JSON form of a knowledge table written in TOML: the same document (entries in
    the TOML's order, one a line), checked by :func:`parse_knowledge` first. The shipped
    ``data/knowledge.json`` is this function of ``data/knowledge.toml``."""
    document = _parse_toml(toml_text, source)
    parse_knowledge(document, source)
    lines = [
        f"{json.dumps(k)}: {json.dumps(v, ensure_ascii=False, separators=(',', ':'))}"
        for k, v in document.items()
    ]
    return "{\n" + ",\n".join(lines) + "\n}\n"


@lru_cache(maxsize=8)
def load_knowledge(path: str | Path | None = None) -> Knowledge:
    """The knowledge table at ``path`` (TOML, or JSON when the name ends in ``.json``), or
    the shipped one (``data/knowledge.json``, read through :mod:`importlib.resources`) when
    ``None``; cached per path."""
    if path is None:
        res = resources.files("causalsplat.reason") / "data" / "knowledge.json"
        source = "knowledge.json"
        try:
            text = res.read_text(encoding="utf-8")
        except FileNotFoundError as exc:
            raise ReasonError(
                f"knowledge data file missing: {res} (generate it with "
                "scripts/make_knowledge_json.py)"
            ) from exc
        return parse_knowledge(_parse_json(text, source), source)
    source, text = str(path), Path(path).read_text(encoding="utf-8")
    if source.endswith(".json"):
        return parse_knowledge(_parse_json(text, source), source)
    return parse_knowledge(_parse_toml(text, source), source)
