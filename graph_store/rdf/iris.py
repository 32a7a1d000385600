"""How scene-graph members are named in RDF.

Every IRI is the scene IRI followed by path segments; each free-text segment (the scene
id, attribute keys and values, evidence and provenance names) is percent-encoded with
``urllib.parse.quote(text, safe="")``, so minted IRIs hold only unreserved ASCII
characters and ``%XX`` escapes and never need escaping in Turtle or N-Triples.
"""

from __future__ import annotations

from functools import lru_cache
from urllib.parse import quote

from graph_store.types import RelationType

#: Every scene IRI starts with this.
SCENE_BASE = "https://w3id.org/causalsplat/scene/"


@lru_cache(maxsize=1 << 14)
def quote_segment(text: str) -> str:
    """``text`` percent-encoded as one IRI path segment (``quote(text, safe="")``)."""
    return quote(text, safe="")


def scene_iri(scene_id: str) -> str:
    """``https://w3id.org/causalsplat/scene/{quoted scene id}``."""
    return SCENE_BASE + quote_segment(scene_id)


def entity_iri(scene_id: str, entity_id: int) -> str:
    """``{scene}/entity/{id}``."""
    return f"{scene_iri(scene_id)}/entity/{int(entity_id)}"


def geometry_iri(entity: str) -> str:
    """``{entity}/geometry``: the GeoSPARQL point of an entity (given its IRI)."""
    return entity + "/geometry"


def attribute_iri(entity: str, key: str, value: str) -> str:
    """``{entity}/attribute/{quoted key}/{quoted value}``."""
    return f"{entity}/attribute/{quote_segment(key)}/{quote_segment(value)}"


def view_iri(scene: str, view_id: int) -> str:
    """``{scene}/view/{id}`` (given the scene IRI)."""
    return f"{scene}/view/{int(view_id)}"


def mask_iri(scene: str, view_id: int, index: int) -> str:
    """``{scene}/view/{view}/mask/{index}``."""
    return f"{scene}/view/{int(view_id)}/mask/{int(index)}"


def relation_iri(scene: str, src: int, rel: RelationType | str, dst: int) -> str:
    """``{scene}/relation/{src}/{type}/{dst}``: the assertion node of one relation."""
    return f"{scene}/relation/{int(src)}/{RelationType.parse(rel).value}/{int(dst)}"


def evidence_iri(assertion: str, name: str) -> str:
    """``{assertion}/evidence/{quoted name}``."""
    return f"{assertion}/evidence/{quote_segment(name)}"


def provenance_iri(scene: str, key: str) -> str:
    """``{scene}/provenance/{quoted key}``."""
    return f"{scene}/provenance/{quote_segment(key)}"
