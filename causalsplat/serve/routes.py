"""The route table: which handler answers which method and path (see :mod:`causalsplat.serve`)."""

from __future__ import annotations

from causalsplat.serve import api, sparql_protocol, static
from causalsplat.serve.app import Route
from causalsplat.serve.splats import get_splats

ROUTES: list[Route] = [
    Route("GET", "/", static.index),
    Route("GET", "/static/{path:path}", static.static_file),
    Route("GET", "/sparql", sparql_protocol.sparql),
    Route("POST", "/sparql", sparql_protocol.sparql),
    Route("OPTIONS", "/sparql", sparql_protocol.preflight),
    Route("GET", "/api/scenes", api.list_scenes),
    Route("GET", "/api/scenes/{scene_id}", api.get_scene),
    Route("GET", "/api/scenes/{scene_id}/entities", api.list_entities),
    Route("GET", "/api/scenes/{scene_id}/entities/{entity_id}", api.get_entity),
    Route("GET", "/api/scenes/{scene_id}/relations", api.list_relations),
    Route("GET", "/api/scenes/{scene_id}/labels", api.get_labels),
    Route("GET", "/api/scenes/{scene_id}/splats", get_splats),
    Route("POST", "/api/scenes/{scene_id}/ask", api.ask),
    Route("POST", "/api/scenes/{scene_id}/query", api.query),
]
