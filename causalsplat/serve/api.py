"""The JSON API: scenes, their entities and relations, per-Gaussian labels, ask, query.

=======  =====================================  ==============================================
method   path                                   answer
=======  =====================================  ==============================================
GET      ``/api/scenes``                        ``{"scenes": [summary...]}``
GET      ``/api/scenes/{id}``                   ``{"scene_id", "meta", "entities", "relations"}``
GET      ``/api/scenes/{id}/entities``          ``{"entities": [entity...]}``
GET      ``/api/scenes/{id}/entities/{eid}``    ``{"entity", "relations"}`` (those it is in)
GET      ``/api/scenes/{id}/relations``         ``{"relations": [...]}`` (``?predicate=above``)
GET      ``/api/scenes/{id}/labels``            little-endian int32 entity id per Gaussian
POST     ``/api/scenes/{id}/ask``               the document of ``causalsplat ask --json``
POST     ``/api/scenes/{id}/query``             the document of ``causalsplat query --json``
=======  =====================================  ==============================================

Entities, relations and scene metadata have the forms of :mod:`graph_store.documents`.
"""

from __future__ import annotations

from typing import Any

from causalsplat.serve.app import App, HttpError, Request, Response, json_response
from graph_store.documents import (
    entity_document,
    relation_document,
    scene_document,
    summary_document,
)

_REASONERS = ("offline", "vlm")
_EXECUTORS = ("sql", "networkx", "memory", "sparql")


def list_scenes(app: App, request: Request, params: dict[str, str]) -> Response:
    return json_response({"scenes": [summary_document(s) for s in app.store.scenes()]})


def get_scene(app: App, request: Request, params: dict[str, str]) -> Response:
    return json_response(scene_document(app.scene(params["scene_id"]).graph))


def list_entities(app: App, request: Request, params: dict[str, str]) -> Response:
    graph = app.scene(params["scene_id"]).graph
    return json_response({"entities": [entity_document(e) for e in graph.entities]})


def get_entity(app: App, request: Request, params: dict[str, str]) -> Response:
    graph = app.scene(params["scene_id"]).graph
    text = params["entity_id"]
    if not text.isascii() or not text.lstrip("-").isdigit():
        raise HttpError(400, f"an entity id is an integer, got {text!r}")
    entity = graph.get_entity(int(text))
    relations = [r for r in graph.relations if entity.id in (r.src, r.dst)]
    return json_response(
        {
            "entity": entity_document(entity),
            "relations": [relation_document(r) for r in relations],
        }
    )


def list_relations(app: App, request: Request, params: dict[str, str]) -> Response:
    from graph_store.types import RelationType

    graph = app.scene(params["scene_id"]).graph
    wanted = request.query.get("predicate", [])
    relations = graph.relations
    if wanted:
        try:
            types = {RelationType.parse(w) for w in wanted}
        except ValueError as exc:
            raise HttpError(400, str(exc)) from None
        relations = tuple(r for r in relations if r.type in types)
    return json_response({"relations": [relation_document(r) for r in relations]})


def get_labels(app: App, request: Request, params: dict[str, str]) -> Response:
    import numpy as np

    scene_id = params["scene_id"]
    labels = app.scene(scene_id).gaussian_labels()
    if labels is None:
        raise HttpError(404, f"scene {scene_id!r} stores no per-Gaussian labels")
    data = np.ascontiguousarray(labels, dtype="<i4").tobytes()
    response = Response(200, data, "application/octet-stream")
    response.headers["X-Count"] = str(len(labels))
    return response


def _body_object(request: Request, what: str) -> dict[str, Any]:
    document = request.json()
    if not isinstance(document, dict):
        raise HttpError(400, f"{what} is a JSON object, got {type(document).__name__}")
    return document


def ask(app: App, request: Request, params: dict[str, str]) -> Response:
    """``{"question": TEXT, "reasoner": "offline"|"vlm", "embeddings": bool}`` (the last two
    optional): the answer, as ``causalsplat ask --json`` prints it."""
    from causalsplat.reason import entity_documents

    body = _body_object(request, "an ask request")
    unknown = sorted(set(body) - {"question", "reasoner", "embeddings"})
    if unknown:
        raise HttpError(400, f"unknown field {unknown[0]!r} (expected question, reasoner)")
    question = body.get("question")
    if not isinstance(question, str):
        raise HttpError(400, 'an ask request needs "question": the instruction as a string')
    reasoner = body.get("reasoner", "offline")
    if reasoner not in _REASONERS:
        raise HttpError(400, f"unknown reasoner {reasoner!r}; expected offline or vlm")
    options: dict[str, Any] = {}
    if "embeddings" in body:
        if not isinstance(body["embeddings"], bool) or reasoner != "offline":
            raise HttpError(400, '"embeddings" is true or false, for the offline reasoner')
        options["embeddings"] = body["embeddings"]
    scene = app.scene(params["scene_id"])
    with app.locked():
        answer = scene.ask(question, reasoner=reasoner, **options)
        entities = entity_documents(answer, {e.id: e for e in scene.entities})
    return json_response(answer.to_dict(entities=entities))


def query(app: App, request: Request, params: dict[str, str]) -> Response:
    """A structured program (its JSON), with optional ``"executor"`` (``sql``, the default,
    ``networkx``, ``memory`` or ``sparql``) and ``"explain": true``: the result, as
    ``causalsplat query --json`` prints it."""
    body = _body_object(request, "a query request")
    executor = body.pop("executor", "sql")
    explain = body.pop("explain", False)
    if executor not in _EXECUTORS:
        raise HttpError(
            400, f"unknown executor {executor!r}; expected sql, networkx, memory or sparql"
        )
    if not isinstance(explain, bool):
        raise HttpError(400, f'"explain" is true or false, got {explain!r}')
    scene = app.scene(params["scene_id"])
    with app.locked():
        result = scene.run(body, executor=executor)
        graph = scene.graph
    document = result.to_dict()
    answer = result.answer
    ids = answer if isinstance(answer, tuple) else ()
    document["entities"] = [
        {"id": e.id, "external_id": e.external_id, "category": e.category}
        for e in (graph.get_entity(i) for i in sorted(ids))
    ]
    if explain:
        document["explain"] = result.explain()
    return json_response(document)
