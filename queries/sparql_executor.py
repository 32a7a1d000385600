"""The SPARQL executor: a program compiled to SPARQL over the RDF view of a scene.

One query per step, evaluated by Oxigraph or rdflib (:mod:`queries.sparql_endpoints`):
every step's set comes out of the engine as entity IRIs, and later steps read it back as
a ``VALUES`` block (the whole scene as ``<scene> bot:containsElement ?e``).
``support_closure`` is the property path ``(csg:supported_by|^csg:supports)+``;
``fall_if_removed`` is an iterative fixpoint, one query per round (candidates are what
rests on the entities added in the previous round); ``coalesce`` sends none (it takes
the first non-empty input, already in hand); ``middle`` sends ``argmin``'s query without
its ``LIMIT`` and keeps the middle of the ordered answer (two of an even count). The
geometric rules of :mod:`queries.semantics` are written into ``FILTER`` / ``BIND``
expressions; the scene centre comes from one aggregate query.

The executor reads the scene's entity ids, distinct categories, captions and attribute
pairs, and its centre, once and keeps them: it assumes the endpoint's data does not change
while it is in use (true of :class:`graph_store.rdf.RdfView` and of the stores
:meth:`from_graph` builds); call :meth:`SparqlExecutor.refresh` otherwise.
"""

from __future__ import annotations

from collections import defaultdict
from typing import Any

from graph_store.types import SceneGraph
from queries._base import Executor, RunValue, middle_of, run_sets
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
from queries.sparql_endpoints import SparqlBackendName, SparqlEndpoint, endpoint_for


class SparqlExecutor(Executor):
    """Runs programs with SPARQL on an endpoint holding the scene's RDF view.

    Build one with :meth:`from_graph` (its own Oxigraph or rdflib store) or pass an
    endpoint (:mod:`queries.sparql_endpoints`), e.g. ``RdfViewEndpoint(view)``.
    """

    name = "sparql"

    def __init__(
        self, endpoint: SparqlEndpoint, scene_id: str, config: QueryConfig = DEFAULT_CONFIG
    ) -> None:
        super().__init__(scene_id, config)
        self.endpoint = endpoint
        self.patterns = Patterns(scene_id)
        self.cache: dict[str, Any] = {}

    @classmethod
    def from_graph(
        cls,
        graph: SceneGraph,
        backend: SparqlBackendName = "oxigraph",
        config: QueryConfig = DEFAULT_CONFIG,
    ) -> SparqlExecutor:
        """An executor over a fresh in-memory store holding ``graph``'s RDF view."""
        return cls(endpoint_for([graph], backend), graph.scene_id, config)

    def refresh(self) -> None:
        """Forget the scene facts read from the endpoint (its entity ids, distinct strings
        and centre); call it when the endpoint's data changed."""
        self.cache.clear()

    def _execute(self, program: GraphQuery) -> QueryResult:
        return _SparqlRun(self).run(program)

    # -- scene facts, read once ----------------------------------------------------------

    def _cached(self, key: str, text: str) -> list[tuple[Any, ...]]:
        if key not in self.cache:
            self.cache[key] = self.endpoint.select(text)
        rows: list[tuple[Any, ...]] = self.cache[key]
        return rows

    def scene_ids(self) -> frozenset[int]:
        """The ids of every entity of the scene (read once, like the other scene facts)."""
        if "scene_ids" not in self.cache:
            text = select_entities(self.patterns.in_scene("e"), distinct=False)
            self.cache["scene_ids"] = frozenset(
                self.patterns.entity_id(iri) for iri in self.endpoint.iris(text)
            )
        ids: frozenset[int] = self.cache["scene_ids"]
        return ids

    def strings(self, prop: str) -> list[str]:
        body = f"{self.patterns.in_scene('e')}?e csg:{prop} ?v .\n"
        rows = self._cached(prop, f"{PROLOGUE}SELECT DISTINCT ?v WHERE {{\n{body}}}")
        return [str(r[0]) for r in rows]

    def attributes(self) -> list[tuple[str, str]]:
        body = (
            f"{self.patterns.in_scene('e')}?e csg:hasAttribute ?a . ?a csg:key ?k ; csg:value ?v ."
        )
        rows = self._cached("attr", f"{PROLOGUE}SELECT DISTINCT ?k ?v WHERE {{\n{body}\n}}")
        return [(str(k), str(v)) for k, v in rows]

    def centre(self) -> tuple[float, float, float]:
        """The scene centre (see :mod:`queries.semantics`) from the extremes the engine reports."""
        aggs = " ".join(
            f"(MIN(?e_{lo}) AS ?{lo}) (MAX(?e_{hi}) AS ?{hi})"
            for lo, hi in (("minX", "maxX"), ("minY", "maxY"), ("minZ", "maxZ"))
        )
        body = self.patterns.in_scene("e") + self.patterns.coords("e", *BOX)
        rows = self._cached("centre", f"{PROLOGUE}SELECT {aggs} WHERE {{\n{body}}}")
        ext = rows[0] if rows and rows[0][0] is not None else (0.0,) * 6
        x, y, z = (
            centre_coordinate(PY, float(ext[2 * i]), float(ext[2 * i + 1])) for i in range(3)
        )
        return (x, y, z)


class _SparqlRun:
    def __init__(self, executor: SparqlExecutor) -> None:
        self.x = executor
        self.ep, self.config, self.p = executor.endpoint, executor.config, executor.patterns
        self.whole: set[int] = set()
        self.paths: list[SupportPath] = []
        self.step_inputs: tuple[int, ...] = ()

    def run(self, program: GraphQuery) -> QueryResult:
        h: dict[Op, Any] = {
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
            Op.COALESCE: self._coalesce,
            Op.SUPPORT_CLOSURE: self._closure,
            Op.FALL_IF_REMOVED: self._fall,
            Op.COUNT: self._count,
            Op.EXISTS: self._exists,
        }

        def handler(op: Op) -> Any:
            def call(i: int, step: Step, ins: list[frozenset[int]]) -> RunValue:
                self.step_inputs = step.inputs
                if op in EMPTY_IN_EMPTY_OUT and not all(ins):
                    return frozenset()  # no query can find anything
                return h[op](i, step, ins)  # type: ignore[no-any-return]

            return call

        handlers = {op: handler(op) for op in h}
        return run_sets(self.x.scene_id, program, handlers, self.paths, SparqlExecutor.name)

    # -- helpers -------------------------------------------------------------------------

    def is_whole(self, pos: int) -> bool:
        return self.step_inputs[pos] in self.whole

    def members(self, var: str, pos: int, ids: frozenset[int]) -> str:
        """Input ``pos`` of the current step on ``?var``."""
        return self.p.members(var, None if self.is_whole(pos) else ids)

    def located(self, var: str, pos: int, ids: frozenset[int], *props: str) -> str:
        """Input ``pos`` on ``?var`` with the given properties, as a sub-select."""
        names = " ".join(f"?{var}_{p}" for p in props)
        return sub_select(
            f"?{var} {names}", self.members(var, pos, ids) + self.p.coords(var, *props)
        )

    def ids(self, text: str) -> frozenset[int]:
        return frozenset(self.p.entity_id(iri) for iri in self.ep.iris(text))

    # -- ops -----------------------------------------------------------------------------

    def _scene(self, i: int, step: Step, ins: list[frozenset[int]]) -> RunValue:
        self.whole.add(i)
        return self.x.scene_ids()

    def _filter_category(self, i: int, step: Step, ins: list[frozenset[int]]) -> RunValue:
        cats = values(
            "?c",
            [literal(c) for c in matching_categories(step.value or "", self.x.strings("category"))],
        )
        if self.is_whole(0):  # this order is the fast one on Oxigraph
            body = f"{cats}?e csg:category ?c .\n{self.p.in_scene('e')}"
        else:
            body = (
                sub_select("?e ?c", f"{self.members('e', 0, ins[0])}?e csg:category ?c .\n") + cats
            )
        return self.ids(select_entities(body))

    def _filter_attribute(self, i: int, step: Step, ins: list[frozenset[int]]) -> RunValue:
        key, value = attribute_filter(step.op.value, step.value or "", self.config)
        pairs = matching_attributes(key, value, self.x.attributes())
        if not pairs:
            return frozenset()
        kv = values("(?k ?v)", [f"({literal(k)} {literal(v)})" for k, v in pairs])
        walk = "?e csg:hasAttribute ?a . ?a csg:key ?k ; csg:value ?v .\n"
        if self.is_whole(0):
            body = kv + walk + self.p.in_scene("e")
        else:
            body = sub_select("?e ?k ?v", self.members("e", 0, ins[0]) + walk) + kv
        return self.ids(select_entities(body))

    def _match_text(self, i: int, step: Step, ins: list[frozenset[int]]) -> RunValue:
        texts = [*self.x.strings("category"), *self.x.strings("caption")]
        ranks = rank_texts(step.value or "", texts)
        if not ranks:
            return frozenset()
        tr = values("(?t ?r)", [f"({literal(t)} {r})" for t, r in sorted(ranks.items())])
        found = sub_select("?e ?r", tr + "{ ?e csg:category ?t } UNION { ?e csg:caption ?t }\n")
        group = f"{found}{self.members('e', 0, ins[0])}?e csg:localId ?id .\n"
        # BOUND: rdflib answers an empty grouped aggregate with one unbound row
        text = (
            f"{PROLOGUE}SELECT ?e ?best WHERE {{\n"
            f"{{ SELECT ?e ?id (MIN(?r) AS ?best) WHERE {{\n{group}}} GROUP BY ?e ?id }}\n"
            f"FILTER (BOUND(?e))\n}} ORDER BY ?best ?id LIMIT {step.effective_k}"
        )
        return self.ids(text)

    def _relate(self, i: int, step: Step, ins: list[frozenset[int]]) -> RunValue:
        rel = step.relation
        assert rel is not None
        if rel.is_view_dependent:
            return self._view_relate(step, ins)
        edge = self.p.relation("e", rel, "a")
        e_side, a_side = self.members("e", 0, ins[0]), self.members("a", 1, ins[1])
        if len(ins[0]) <= len(ins[1]):  # walk from the smaller side
            body = sub_select("?e ?a", e_side + edge) + a_side
        else:
            body = sub_select("?e ?a", a_side + edge) + e_side
        return self.ids(select_entities(body))

    def _view_relate(self, step: Step, ins: list[frozenset[int]]) -> RunValue:
        rel = step.relation
        assert rel is not None
        vp = step.viewpoint
        if vp is None:
            cx, cy, _ = self.x.centre()
            eye, target = (double(cx), double(cy)), ("?a_centroidX", "?a_centroidY")
        else:
            eye = (double(vp.eye[0]), double(vp.eye[1]))
            target = (double(vp.target[0]), double(vp.target[1]))
        s_xy, a_xy = ("?e_centroidX", "?e_centroidY"), ("?a_centroidX", "?a_centroidY")
        cond = view_relation(SPARQL, rel, s_xy, a_xy, eye, target)
        body = self.located("e", 0, ins[0], *XY) + self.located("a", 1, ins[1], *XY)
        return self.ids(select_entities(f"{body}FILTER {cond}\n"))

    def _between(self, i: int, step: Step, ins: list[frozenset[int]]) -> RunValue:
        names = ("e", "a", "b")
        body = "".join(self.located(v, n, ins[n], *XY) for n, v in enumerate(names))
        xy = [(f"?{v}_centroidX", f"?{v}_centroidY") for v in names]
        cond = between(SPARQL, xy[0], xy[1], xy[2], self.config.between_lateral_ratio)
        return self.ids(select_entities(f"{body}FILTER {cond}\n"))

    def _rank(self, i: int, step: Step, ins: list[frozenset[int]]) -> RunValue:
        metric = step.metric
        assert metric is not None
        centroid = ("?e_centroidX", "?e_centroidY", "?e_centroidZ")
        if metric.is_segment:
            triples = (
                self.located("e", 0, ins[0], "localId", *XY)
                + self.located("a", 1, ins[1], *XY)
                + self.located("b", 2, ins[2], *XY)
            )
            xy = [(f"?{v}_centroidX", f"?{v}_centroidY") for v in ("e", "a", "b")]
            d = segment_distance(SPARQL, *xy)
            keyed = smallest_per_entity(d, triples, "(?e != ?a && ?e != ?b && ?a != ?b)")
        elif not metric.is_distance:
            lo, hi = ("?e_minX", "?e_minY", "?e_minZ"), ("?e_maxX", "?e_maxY", "?e_maxZ")
            value = metric_value(
                SPARQL, metric.value, centroid, lo, hi, view_consts(SPARQL, step.viewpoint)
            )
            body = self.located("e", 0, ins[0], "localId", *XYZ, *BOX)
            keyed = f"{body}BIND (({value}) AS ?v)\n"
        elif len(ins) == 2:
            a_xyz = ("?a_centroidX", "?a_centroidY", "?a_centroidZ")
            pairs = self.located("e", 0, ins[0], "localId", *XYZ)
            boxed = metric.uses_box  # the anchor's box only when it is used
            pairs += self.located("a", 1, ins[1], *XYZ, *(BOX if boxed else ()))
            a_lo, a_hi = ("?a_minX", "?a_minY", "?a_minZ"), ("?a_maxX", "?a_maxY", "?a_maxZ")
            d = reference_distance(SPARQL, metric.value, centroid, a_xyz, a_lo, a_hi)
            keyed = smallest_per_entity(d, pairs, "(?e != ?a)")
        else:
            c = tuple(double(x) for x in self.x.centre())
            point = (c[0], c[1], c[2])
            d = reference_distance(SPARQL, metric.value, centroid, point, point, point)
            keyed = f"{self.located('e', 0, ins[0], 'localId', *XYZ)}BIND ({d} AS ?v)\n"
        order = "DESC(?v)" if step.op is Op.ARGMAX else "?v"
        text = f"{PROLOGUE}SELECT ?e ?v WHERE {{\n{keyed}}} ORDER BY {order} ?e_localId"
        if step.op is Op.MIDDLE:  # every candidate in argmin's order, the middle kept here
            ordered = [self.p.entity_id(iri) for iri in self.ep.iris(text)]
            return middle_of(ordered)
        return self.ids(f"{text} LIMIT {step.effective_k}")

    def _set_op(self, i: int, step: Step, ins: list[frozenset[int]]) -> RunValue:
        parts = [self.members("e", n, s) for n, s in enumerate(ins)]
        if step.op is Op.UNION:
            parts = [p for p, s in zip(parts, ins, strict=True) if s]
            if not parts:
                return frozenset()
            body = " UNION ".join(f"{{ {p} }}" for p in parts) + "\n"
        elif step.op is Op.INTERSECT:
            body = "".join(parts)
        elif not ins[0]:
            return frozenset()
        else:
            body = f"{parts[0]}MINUS {{ {parts[1]} }}\n"
        return self.ids(select_entities(body))

    def _coalesce(self, i: int, step: Step, ins: list[frozenset[int]]) -> RunValue:
        return next((s for s in ins if s), frozenset())

    def _closure(self, i: int, step: Step, ins: list[frozenset[int]]) -> RunValue:
        body = f"{self.members('s', 0, ins[0])}?e {SUPPORT_PATH}+ ?s .\n"
        return self.ids(select_entities(body))

    def _fall(self, i: int, step: Step, ins: list[frozenset[int]]) -> RunValue:
        removed = ins[0]
        structural = [c for c in self.x.strings("category") if self.config.is_structural(c)]
        not_structural = f"FILTER (?cat NOT IN ({', '.join(literal(c) for c in structural)}))\n"
        rounds: dict[int, int] = {}
        known, frontier = set(removed), set(removed)
        current = 0
        while frontier:
            current += 1
            iris = self.p.iri_list(known)
            resting = sub_select(
                "DISTINCT ?e",
                f"{self.p.members('y0', frozenset(frontier))}?e {SUPPORT_PATH} ?y0 .\n",
            )
            body = (
                f"{resting}?e csg:category ?cat .\nFILTER (?e NOT IN ({iris}))\n{not_structural}"
                f"FILTER NOT EXISTS {{ ?e {SUPPORT_PATH} ?y . FILTER (?y NOT IN ({iris})) }}\n"
            )
            frontier = set(self.ids(select_entities(body)))
            rounds.update((x, current) for x in frontier)
            known |= frontier
        if rounds:
            text = (
                f"{PROLOGUE}SELECT DISTINCT ?x ?y WHERE {{\n"
                f"{self.p.members('x', frozenset(rounds))}?x {SUPPORT_PATH} ?y .\n}}"
            )
            supporters: dict[int, list[int]] = defaultdict(list)
            for x, y in self.ep.select(text):
                supporters[self.p.entity_id(str(x))].append(self.p.entity_id(str(y)))
            self.paths.extend(support_paths(i, removed, rounds, supporters))
        return frozenset(rounds)

    def _count(self, i: int, step: Step, ins: list[frozenset[int]]) -> RunValue:
        body = self.members("e", 0, ins[0])
        text = f"{PROLOGUE}SELECT (COUNT(DISTINCT ?e) AS ?n) WHERE {{\n{body}}}"
        return int(self.ep.select(text)[0][0])

    def _exists(self, i: int, step: Step, ins: list[frozenset[int]]) -> RunValue:
        return self.ep.ask(f"{PROLOGUE}ASK {{\n{self.members('e', 0, ins[0])}}}")
