"""The SPARQL executor over many scenes: one query per step for every selected scene.

The steps compile as in :mod:`queries.sparql_executor`, but an input set is the members of
every selected scene at once (:mod:`queries._sparql_many_steps`): entity IRIs name their
scene, so one ``VALUES`` block holds them all and the engine's answer splits into
per-scene sets by IRI; a whole-scene input is ``VALUES ?scene { <scene> ... } ?scene
bot:containsElement ?e`` (without the ``VALUES`` block when the endpoint holds only the
selected scenes, as :func:`queries.run_program_all`'s dataset does). The number of queries
depends on the program, never on the number of scenes:

* one query per step: ``filter_category``, ``filter_attribute``, ``filter_affordance``,
  ``match_text``, ``relate`` (stored and view-dependent), ``relate_between``, ``argmin``,
  ``argmax``, ``middle`` and ``support_closure``;
* ``fall_if_removed``: one query per round for all scenes (a scene's round ``r`` reads only
  its own IRIs, so its rounds are those of its own run; a scene whose fixpoint is reached
  drops out of later rounds), then one query for the fallen entities' supporters. The
  entities known to be gone are ``MINUS`` anti-joins rather than the per-scene executor's
  ``NOT IN`` lists, which would compare every candidate with every scene's removed
  entities (seconds over 1,500 scans);
* ``scene``: one query for the entities of all selected scenes, once per run;
* no query: ``union``, ``intersect``, ``difference`` (set algebra on IRIs already in
  hand), ``coalesce`` (each scene's first non-empty input, in hand), ``count`` and
  ``exists`` (the size of a set in hand, per scene).

The scene facts are one query each for all scenes: the distinct categories, captions and
attribute pairs of every scene the endpoint holds (every rule of :mod:`queries.semantics`
that picks stored strings looks at one string at a time, and ``match_text`` ranks are only
compared within a scene, so the strings of other scenes change no scene's answer), and
each scene's centre (one aggregate ``GROUP BY ?scene``, written back as a ``VALUES (?scene
?cx ?cy ?cz)`` block of the doubles the per-scene executor writes into its query).

SPARQL 1.1 has no window function to keep the first ``k`` rows of each scene, so
``match_text``, ``argmin`` and ``argmax`` send the per-scene query without its ``LIMIT``:
the engine computes every candidate's key and sorts all scenes' rows by the per-scene
``ORDER BY`` (key, then local id), and the first ``k`` rows of each scene are kept in
Python; ``middle`` sends its query so too (the per-scene executor also asks it without a
``LIMIT``) and keeps each scene's middle row (two of an even count). A global sort orders
each scene's rows exactly as that scene's own sort does, so ties are broken alike. An op
with an empty input in a scene is empty there without asking the engine (as in the
per-scene executor); such scenes are left out of the step's query, and a step with no
scene left sends none.

Every scene's :class:`~queries.QueryResult` (answer, step values, support paths) equals
:class:`~queries.sparql_executor.SparqlExecutor`'s on that scene.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from queries._base import RunValue, as_set, step_value
from queries._sparql_many_steps import ByScene, ManyPatterns
from queries._sparql_steps import (
    BOX,
    EMPTY_IN_EMPTY_OUT,
    PROLOGUE,
    SPARQL,
    SUPPORT_PATH,
    XY,
    XYZ,
    Patterns,
    double,
    literal,
    select_entities,
    smallest_per_entity,
    sub_select,
    values,
)
from queries.model import GraphQuery, Op, Step
from queries.result import QueryResult
from queries.semantics import (
    DEFAULT_CONFIG,
    PY,
    QueryConfig,
    SupportPath,
    attribute_filter,
    between,
    centre_coordinate,
    matching_attributes,
    matching_categories,
    metric_value,
    rank_texts,
    reference_distance,
    segment_distance,
    support_paths,
    view_consts,
    view_relation,
)
from queries.sparql_endpoints import SparqlEndpoint
from queries.sparql_executor import SparqlExecutor

_CENTRE = ("?cx", "?cy", "?cz")

Handler = Callable[[int, Step, list[ByScene], list[str]], Mapping[str, RunValue]]


def run_sparql_many(
    endpoint: SparqlEndpoint,
    scene_ids: Sequence[str],
    program: GraphQuery | str | bytes | dict[str, Any],
    config: QueryConfig = DEFAULT_CONFIG,
    *,
    all_scenes: bool = False,
) -> dict[str, QueryResult]:
    """``program``'s result on each of ``scene_ids``, whose RDF views ``endpoint`` holds.

    The endpoint may hold other scenes too, and queries are limited to the given ones;
    ``all_scenes`` says that it holds no other scene, so whole-scene patterns need no
    scene filter (a ``VALUES`` block of every scene IRI, which costs Oxigraph a join with
    every entity). Raises :class:`~queries.QueryExecutionError` when the engine fails.

    >>> from queries.sparql_endpoints import endpoint_for
    >>> from graph_store.types import Entity, SceneGraph, SceneMeta
    >>> def scene(sid, n):
    ...     ents = [Entity(i, "cup", (float(i), 0.0, 0.0), (i - 0.1, -0.1, -0.1),
    ...                    (i + 0.1, 0.1, 0.1)) for i in range(n)]
    ...     return SceneGraph(SceneMeta(sid), tuple(ents), ())
    >>> graphs = [scene("a", 3), scene("b", 0), scene("c", 5)]
    >>> program = {"query_type": "intrinsic", "answer_step": 2, "steps": [
    ...     {"op": "scene"}, {"op": "filter_category", "inputs": [0], "value": "Cup"},
    ...     {"op": "argmax", "inputs": [1], "metric": "x", "k": 2}]}
    >>> out = run_sparql_many(endpoint_for(graphs, "oxigraph"), ["a", "b", "c"], program)
    >>> {sid: r.answer for sid, r in out.items()}
    {'a': (1, 2), 'b': (), 'c': (3, 4)}
    """
    ids = tuple(sorted(set(scene_ids)))
    if not ids:
        return {}
    return _ManyRun(endpoint, ids, config, all_scenes).run(GraphQuery.parse(program))


class _ManyRun:
    def __init__(
        self,
        endpoint: SparqlEndpoint,
        scene_ids: tuple[str, ...],
        config: QueryConfig,
        every: bool,
    ) -> None:
        self.ep, self.config = endpoint, config
        self.scene_ids = scene_ids
        self.p = ManyPatterns(scene_ids, every=every)
        self.whole: set[int] = set()
        self.paths: dict[str, list[SupportPath]] = defaultdict(list)
        self.facts: dict[str, Any] = {}
        self.step_inputs: tuple[int, ...] = ()

    def run(self, program: GraphQuery) -> dict[str, QueryResult]:
        h: dict[Op, Handler] = {
            Op.SCENE: self._scene,
            Op.FILTER_CATEGORY: self._filter_category,
            Op.FILTER_ATTRIBUTE: self._filter_attribute,
            Op.FILTER_AFFORDANCE: self._filter_attribute,
            Op.MATCH_TEXT: self._match_text,
            Op.RELATE: self._relate,
            Op.RELATE_BETWEEN: self._between,
            Op.ARGMIN: self._rank,
            Op.ARGMAX: self._rank,
            Op.MIDDLE: self._rank,
            Op.UNION: self._set_op,
            Op.INTERSECT: self._set_op,
            Op.DIFFERENCE: self._set_op,
            Op.COALESCE: self._set_op,
            Op.SUPPORT_CLOSURE: self._closure,
            Op.FALL_IF_REMOVED: self._fall,
            Op.COUNT: self._count,
            Op.EXISTS: self._exists,
        }
        steps: list[dict[str, RunValue]] = []
        for i, step in enumerate(program.steps):
            self.step_inputs = step.inputs
            ins = [{sid: as_set(steps[j][sid]) for sid in self.scene_ids} for j in step.inputs]
            live = list(self.scene_ids)
            if step.op in EMPTY_IN_EMPTY_OUT:  # empty there, no query can find anything
                live = [sid for sid in live if all(s[sid] for s in ins)]
            out = h[step.op](i, step, ins, live) if live else {}
            steps.append({sid: out.get(sid, frozenset()) for sid in self.scene_ids})
        results = {}
        for sid in self.scene_ids:
            values_ = tuple(step_value(s[sid]) for s in steps)
            results[sid] = QueryResult(
                scene_id=sid,
                program=program,
                answer=values_[program.answer_step],
                steps=values_,
                support_paths=tuple(sorted(self.paths.get(sid, ()))),
                executor=SparqlExecutor.name,
            )
        return results

    # -- scene facts, one query each for every selected scene ----------------------------

    def _fact(self, key: str, text: str) -> list[tuple[Any, ...]]:
        if key not in self.facts:
            self.facts[key] = self.ep.select(text)
        rows: list[tuple[Any, ...]] = self.facts[key]
        return rows

    def _all(self, var: str = "e") -> str:
        return self.p.whole(var, self.scene_ids, "scene")

    # The stored strings of every scene the endpoint holds: each rule picks strings one at
    # a time and ranks are compared within a scene, so other scenes' strings change nothing
    # (and a scope would cost a join with every entity).

    def strings(self, prop: str) -> list[str]:
        body = f"?e csg:{prop} ?v .\n"
        rows = self._fact(prop, f"{PROLOGUE}SELECT DISTINCT ?v WHERE {{\n{body}}}")
        return [str(r[0]) for r in rows]

    def attributes(self) -> list[tuple[str, str]]:
        body = "?e csg:hasAttribute ?a . ?a csg:key ?k ; csg:value ?v .\n"
        rows = self._fact("attr", f"{PROLOGUE}SELECT DISTINCT ?k ?v WHERE {{\n{body}}}")
        return [(str(k), str(v)) for k, v in rows]

    def centres(self) -> dict[str, tuple[float, float, float]]:
        """Each scene's centre, as :meth:`SparqlExecutor.centre` works it out."""
        if "centres" not in self.facts:
            aggs = " ".join(
                f"(MIN(?e_{lo}) AS ?{lo}) (MAX(?e_{hi}) AS ?{hi})"
                for lo, hi in (("minX", "maxX"), ("minY", "maxY"), ("minZ", "maxZ"))
            )
            body = self._all() + Patterns.coords("e", *BOX)
            text = f"{PROLOGUE}SELECT ?scene {aggs} WHERE {{\n{body}}} GROUP BY ?scene"
            by_iri = {iri[1:-1]: sid for sid, iri in self.p.scene.items()}
            centres = {}
            for row in self.ep.select(text):
                if row[0] is None or row[1] is None:  # rdflib: an empty group's unbound row
                    continue
                centres[by_iri[str(row[0])]] = tuple(
                    centre_coordinate(PY, float(row[2 * i + 1]), float(row[2 * i + 2]))
                    for i in range(3)
                )
            self.facts["centres"] = centres
        found: dict[str, tuple[float, float, float]] = self.facts["centres"]
        return found

    def centre_values(self, live: list[str], axes: int) -> str:
        """``VALUES (?scene ?cx ?cy [?cz])``: the centre of each of ``live``."""
        centres = self.centres()
        rows = []
        for sid in live:
            c = centres.get(sid, (0.0, 0.0, 0.0))
            rows.append(f"({self.p.scene[sid]} {' '.join(double(x) for x in c[:axes])})")
        return values(f"(?scene {' '.join(_CENTRE[:axes])})", rows)

    # -- helpers -------------------------------------------------------------------------

    def is_whole(self, pos: int) -> bool:
        return self.step_inputs[pos] in self.whole

    def members(
        self, var: str, pos: int, ins: list[ByScene], live: list[str], scene: bool = False
    ) -> str:
        """Input ``pos`` of the current step on ``?var`` (and its scene on ``?scene``)."""
        if self.is_whole(pos):
            return self.p.whole(var, live, "scene" if scene else f"{var}_scene")
        return self.p.members(var, ins[pos], live, "scene" if scene else None)

    def located(self, var: str, pos: int, ins: list[ByScene], live: list[str], *props: str) -> str:
        """Input ``pos`` on ``?var`` with its scene and the given properties, a sub-select."""
        names = " ".join(f"?{var}_{p}" for p in props)
        body = self.members(var, pos, ins, live, scene=True) + Patterns.coords(var, *props)
        return sub_select(f"?{var} ?scene {names}", body)

    def ids(self, text: str) -> ByScene:
        return self.p.by_scene(self.ep.iris(text))

    # -- ops -----------------------------------------------------------------------------

    def _scene(self, i: int, step: Step, ins: list[ByScene], live: list[str]) -> ByScene:
        self.whole.add(i)
        if "entities" not in self.facts:
            text = select_entities(self._all(), distinct=False)
            self.facts["entities"] = self.ids(text)
        entities: ByScene = self.facts["entities"]
        return entities

    def _filter_category(self, i: int, step: Step, ins: list[ByScene], live: list[str]) -> ByScene:
        cats = matching_categories(step.value or "", self.strings("category"))
        if not cats:
            return {}
        c = values("?c", [literal(x) for x in cats])
        if self.is_whole(0):  # the fast order on Oxigraph, as for one scene
            body = f"{c}?e csg:category ?c .\n{self.members('e', 0, ins, live)}"
        else:
            body = sub_select("?e ?c", f"{self.members('e', 0, ins, live)}?e csg:category ?c .\n")
            body += c
        return self.ids(select_entities(body))

    def _filter_attribute(self, i: int, step: Step, ins: list[ByScene], live: list[str]) -> ByScene:
        key, value = attribute_filter(step.op.value, step.value or "", self.config)
        pairs = matching_attributes(key, value, self.attributes())
        if not pairs:
            return {}
        kv = values("(?k ?v)", [f"({literal(k)} {literal(v)})" for k, v in pairs])
        walk = "?e csg:hasAttribute ?a . ?a csg:key ?k ; csg:value ?v .\n"
        if self.is_whole(0):
            body = kv + walk + self.members("e", 0, ins, live)
        else:
            body = sub_select("?e ?k ?v", self.members("e", 0, ins, live) + walk) + kv
        return self.ids(select_entities(body))

    def _match_text(self, i: int, step: Step, ins: list[ByScene], live: list[str]) -> ByScene:
        ranks = rank_texts(step.value or "", [*self.strings("category"), *self.strings("caption")])
        if not ranks:
            return {}
        tr = values("(?t ?r)", [f"({literal(t)} {r})" for t, r in sorted(ranks.items())])
        found = sub_select("?e ?r", tr + "{ ?e csg:category ?t } UNION { ?e csg:caption ?t }\n")
        group = f"{found}{self.members('e', 0, ins, live)}?e csg:localId ?id .\n"
        text = (  # BOUND: rdflib answers an empty grouped aggregate with one unbound row
            f"{PROLOGUE}SELECT ?e ?best WHERE {{\n"
            f"{{ SELECT ?e ?id (MIN(?r) AS ?best) WHERE {{\n{group}}} GROUP BY ?e ?id }}\n"
            f"FILTER (BOUND(?e))\n}} ORDER BY ?best ?id"
        )
        return self.p.first_k(self.ep.iris(text), step.effective_k)

    def _relate(self, i: int, step: Step, ins: list[ByScene], live: list[str]) -> ByScene:
        rel = step.relation
        assert rel is not None
        if rel.is_view_dependent:
            return self._view_relate(step, ins, live)
        edge = Patterns.relation("e", rel, "a")
        e_side, a_side = self.members("e", 0, ins, live), self.members("a", 1, ins, live)
        sizes = [sum(len(s[sid]) for sid in live) for s in ins]
        if sizes[0] <= sizes[1]:  # walk from the smaller side
            body = sub_select("?e ?a", e_side + edge) + a_side
        else:
            body = sub_select("?e ?a", a_side + edge) + e_side
        return self.ids(select_entities(body))

    def _view_relate(self, step: Step, ins: list[ByScene], live: list[str]) -> ByScene:
        rel = step.relation
        assert rel is not None
        vp = step.viewpoint
        body = self.located("e", 0, ins, live, *XY) + self.located("a", 1, ins, live, *XY)
        if vp is None:
            body += self.centre_values(live, 2)
            eye, target = (_CENTRE[0], _CENTRE[1]), ("?a_centroidX", "?a_centroidY")
        else:
            eye = (double(vp.eye[0]), double(vp.eye[1]))
            target = (double(vp.target[0]), double(vp.target[1]))
        s_xy, a_xy = ("?e_centroidX", "?e_centroidY"), ("?a_centroidX", "?a_centroidY")
        cond = view_relation(SPARQL, rel, s_xy, a_xy, eye, target)
        return self.ids(select_entities(f"{body}FILTER {cond}\n"))

    def _between(self, i: int, step: Step, ins: list[ByScene], live: list[str]) -> ByScene:
        names = ("e", "a", "b")
        body = "".join(self.located(v, n, ins, live, *XY) for n, v in enumerate(names))
        xy = [(f"?{v}_centroidX", f"?{v}_centroidY") for v in names]
        cond = between(SPARQL, xy[0], xy[1], xy[2], self.config.between_lateral_ratio)
        return self.ids(select_entities(f"{body}FILTER {cond}\n"))

    def _rank(self, i: int, step: Step, ins: list[ByScene], live: list[str]) -> ByScene:
        metric = step.metric
        assert metric is not None
        centroid = ("?e_centroidX", "?e_centroidY", "?e_centroidZ")
        if metric.is_segment:
            triples = (
                self.located("e", 0, ins, live, "localId", *XY)
                + self.located("a", 1, ins, live, *XY)
                + self.located("b", 2, ins, live, *XY)
            )
            xy = [(f"?{v}_centroidX", f"?{v}_centroidY") for v in ("e", "a", "b")]
            d = segment_distance(SPARQL, *xy)
            keyed = smallest_per_entity(d, triples, "(?e != ?a && ?e != ?b && ?a != ?b)")
        elif not metric.is_distance:
            lo, hi = ("?e_minX", "?e_minY", "?e_minZ"), ("?e_maxX", "?e_maxY", "?e_maxZ")
            value = metric_value(
                SPARQL, metric.value, centroid, lo, hi, view_consts(SPARQL, step.viewpoint)
            )
            body = self.located("e", 0, ins, live, "localId", *XYZ, *BOX)
            keyed = f"{body}BIND (({value}) AS ?v)\n"
        elif len(ins) == 2:
            a_xyz = ("?a_centroidX", "?a_centroidY", "?a_centroidZ")
            pairs = self.located("e", 0, ins, live, "localId", *XYZ)
            boxed = metric.uses_box  # the anchor's box only when it is used
            pairs += self.located("a", 1, ins, live, *XYZ, *(BOX if boxed else ()))
            a_lo, a_hi = ("?a_minX", "?a_minY", "?a_minZ"), ("?a_maxX", "?a_maxY", "?a_maxZ")
            d = reference_distance(SPARQL, metric.value, centroid, a_xyz, a_lo, a_hi)
            keyed = smallest_per_entity(d, pairs, "(?e != ?a)")
        else:
            d = reference_distance(SPARQL, metric.value, centroid, _CENTRE, _CENTRE, _CENTRE)
            body = self.located("e", 0, ins, live, "localId", *XYZ) + self.centre_values(live, 3)
            keyed = f"{body}BIND ({d} AS ?v)\n"
        order = "DESC(?v)" if step.op is Op.ARGMAX else "?v"
        text = f"{PROLOGUE}SELECT ?e ?v WHERE {{\n{keyed}}} ORDER BY {order} ?e_localId"
        if step.op is Op.MIDDLE:
            return self.p.middle(self.ep.iris(text))
        return self.p.first_k(self.ep.iris(text), step.effective_k)

    def _set_op(self, i: int, step: Step, ins: list[ByScene], live: list[str]) -> ByScene:
        if step.op is Op.UNION:
            return {sid: frozenset().union(*(s[sid] for s in ins)) for sid in live}
        if step.op is Op.INTERSECT:
            return {sid: frozenset.intersection(*(s[sid] for s in ins)) for sid in live}
        if step.op is Op.COALESCE:  # the first input non-empty in each scene
            return {sid: next((s[sid] for s in ins if s[sid]), frozenset()) for sid in live}
        return {sid: ins[0][sid] - ins[1][sid] for sid in live}

    def _closure(self, i: int, step: Step, ins: list[ByScene], live: list[str]) -> ByScene:
        body = f"{self.members('s', 0, ins, live)}?e {SUPPORT_PATH}+ ?s .\n"
        return self.ids(select_entities(body))

    def _fall(self, i: int, step: Step, ins: list[ByScene], live: list[str]) -> ByScene:
        removed = {sid: ins[0][sid] for sid in live}
        structural = [c for c in self.strings("category") if self.config.is_structural(c)]
        not_structural = f"FILTER (?cat NOT IN ({', '.join(literal(c) for c in structural)}))\n"
        rounds: dict[str, dict[int, int]] = defaultdict(dict)
        known = {sid: set(ids) for sid, ids in removed.items()}
        frontier: Mapping[str, frozenset[int]] = removed
        current = 0
        while active := [sid for sid in live if frontier.get(sid)]:
            current += 1
            resting = sub_select(
                "DISTINCT ?e", f"{self.p.members('y0', frontier, active)}?e {SUPPORT_PATH} ?y0 .\n"
            )
            # MINUS, not the per-scene NOT IN lists: an anti-join, where a NOT IN list
            # compares every candidate with every known entity of every scene
            body = (
                f"{resting}MINUS {{ {self.p.members('e', known, active)}}}\n"
                f"?e csg:category ?cat .\n{not_structural}"
                f"MINUS {{\n{resting}?e {SUPPORT_PATH} ?y .\n"
                f"MINUS {{ {self.p.members('y', known, active)}}}\n}}\n"
            )
            frontier = self.ids(select_entities(body))
            for sid in active:
                rounds[sid].update((x, current) for x in frontier[sid])
                known[sid] |= frontier[sid]
        fell = {sid: frozenset(r) for sid, r in rounds.items() if r}
        if fell:
            text = (
                f"{PROLOGUE}SELECT DISTINCT ?x ?y WHERE {{\n"
                f"{self.p.members('x', fell, sorted(fell))}?x {SUPPORT_PATH} ?y .\n}}"
            )
            supporters: dict[str, dict[int, list[int]]] = defaultdict(lambda: defaultdict(list))
            for x, y in self.ep.select(text):
                sid, upper = self.p.split(str(x))
                supporters[sid][upper].append(self.p.split(str(y))[1])
            for sid in fell:
                self.paths[sid].extend(support_paths(i, removed[sid], rounds[sid], supporters[sid]))
        return fell

    def _count(self, i: int, step: Step, ins: list[ByScene], live: list[str]) -> dict[str, int]:
        return {sid: len(ins[0][sid]) for sid in live}

    def _exists(self, i: int, step: Step, ins: list[ByScene], live: list[str]) -> dict[str, bool]:
        return {sid: bool(ins[0][sid]) for sid in live}
