"""SPARQL patterns over many scenes at once, for :mod:`queries.sparql_many`.

The multi-scene twin of :class:`queries._sparql_steps.Patterns`. An entity IRI names its
scene (``{scene}/entity/{id}``, :mod:`graph_store.rdf.iris`), so a set of entities drawn
from many scenes is still one ``VALUES ?v { <iri> ... }`` block, a stored edge or a support
path never leaves its scene, and every IRI an engine returns tells which scene it is in
(:meth:`ManyPatterns.split`). Patterns that pair entities of one scene (view-dependent
relations, ``relate_between``, distances to a reference set or to the scene centre) bind
each side's scene to one ``?scene`` variable.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Mapping, Sequence

from graph_store.rdf.iris import entity_iri, scene_iri
from queries._base import middle_of
from queries._sparql_steps import values
from queries.errors import QueryExecutionError

#: A step's value over many scenes: scene id -> entity ids (every selected scene a key).
ByScene = dict[str, frozenset[int]]


class ManyPatterns:
    """Pattern builders for the selected scenes (sorted ids).

    >>> p = ManyPatterns(["a", "b/1"])
    >>> p.iri("b/1", 7)
    '<https://w3id.org/causalsplat/scene/b%2F1/entity/7>'
    >>> p.split("https://w3id.org/causalsplat/scene/b%2F1/entity/7")
    ('b/1', 7)
    >>> p.members("e", {"a": frozenset({2}), "b/1": frozenset({7})}, ["a"], "scene")
    'VALUES ?e { <https://w3id.org/causalsplat/scene/a/entity/2> }\\n?e csg:inScene ?scene .\\n'
    """

    def __init__(self, scene_ids: Sequence[str], *, every: bool = False) -> None:
        self.scene_ids = tuple(scene_ids)
        #: the endpoint holds no other scene, so a whole-scene pattern needs no scene filter
        self.every = every
        self.scene = {sid: f"<{scene_iri(sid)}>" for sid in self.scene_ids}
        self._prefix = {sid: entity_iri(sid, 0)[:-1] for sid in self.scene_ids}
        self._by_base = {scene_iri(sid): sid for sid in self.scene_ids}

    def iri(self, scene_id: str, entity_id: int) -> str:
        return f"<{self._prefix[scene_id]}{int(entity_id)}>"

    def split(self, iri: str) -> tuple[str, int]:
        """``(scene id, local id)`` of an entity IRI of a selected scene."""
        base, sep, tail = iri.rpartition("/entity/")
        scene_id = self._by_base.get(base) if sep else None
        if scene_id is None or not tail.isdigit():
            raise QueryExecutionError(f"{iri!r} is not an entity of a selected scene")
        return scene_id, int(tail)

    def by_scene(self, iris: Iterable[str]) -> ByScene:
        """The entities ``iris`` name, grouped by scene (every selected scene a key)."""
        out: dict[str, set[int]] = {sid: set() for sid in self.scene_ids}
        for iri in iris:
            sid, x = self.split(iri)
            out[sid].add(x)
        return {sid: frozenset(ids) for sid, ids in out.items()}

    def first_k(self, ordered: Iterable[str], k: int) -> ByScene:
        """The first ``k`` entities of each scene in ``ordered`` (a query's ``ORDER BY``
        over all scenes orders each scene's rows as that scene's own query would)."""
        out: dict[str, list[int]] = {sid: [] for sid in self.scene_ids}
        for iri in ordered:
            sid, x = self.split(iri)
            if len(out[sid]) < k:  # rows, as LIMIT counts them
                out[sid].append(x)
        return {sid: frozenset(ids) for sid, ids in out.items()}

    def middle(self, ordered: Iterable[str]) -> ByScene:
        """The middle entity of each scene in ``ordered`` (two of an even count; a query's
        ``ORDER BY`` over all scenes orders each scene's rows as that scene's own query
        would)."""
        out: dict[str, list[int]] = {sid: [] for sid in self.scene_ids}
        for iri in ordered:
            sid, x = self.split(iri)
            out[sid].append(x)
        return {sid: middle_of(ids) for sid, ids in out.items()}

    def scenes(self, var: str, scene_ids: Iterable[str]) -> str:
        """``VALUES ?var { <scene> ... }``."""
        return values(f"?{var}", [self.scene[sid] for sid in scene_ids])

    def whole(self, var: str, scene_ids: Iterable[str], scene_var: str) -> str:
        """``?var`` ranges over the entities of ``scene_ids``, ``?scene_var`` over their scene.

        With :attr:`every`, over the entities of every scene the endpoint holds: the callers
        join a whole-scene input with the other inputs within a scene, or read it alone, so
        a scene left out of ``scene_ids`` for an empty input adds nothing.
        """
        contains = f"?{scene_var} bot:containsElement ?{var} .\n"
        return contains if self.every else self.scenes(scene_var, scene_ids) + contains

    def members(
        self,
        var: str,
        sets: Mapping[str, Collection[int]],
        scene_ids: Iterable[str],
        scene_var: str | None = None,
    ) -> str:
        """``?var`` ranges over the members of ``sets`` in ``scene_ids`` (and ``?scene_var``,
        when given, over their scene)."""
        rows = [self.iri(sid, x) for sid in scene_ids for x in sorted(sets.get(sid, ()))]
        text = values(f"?{var}", rows)
        if scene_var is not None:
            text += f"?{var} csg:inScene ?{scene_var} .\n"
        return text
