"""graph_store: the persisted scene-graph store of CausalSplat.

Types (:class:`Entity`, :class:`Relation`, :class:`SceneGraph`...), the database
repository (:func:`open_store`), the RDF vocabulary, export/import, and read-only SPARQL.
This package never imports torch.
"""

from graph_store._engine import as_url
from graph_store.errors import (
    EntityNotFound,
    GraphStoreError,
    InvalidSceneError,
    RDFFormatError,
    SceneExistsError,
    SceneNotFound,
    SchemaVersionError,
    SparqlArgumentError,
    SparqlError,
    SparqlForbiddenError,
    SparqlFormatError,
    SparqlResourceError,
    SparqlRowLimitError,
    SparqlSyntaxError,
    SparqlTimeoutError,
    StoreConnectionError,
    StoreNotFoundError,
)
from graph_store.labels import decode_labels
from graph_store.repository import GraphStore, SceneSummary, open_store
from graph_store.types import (
    STORED_RELATION_TYPES,
    Attribute,
    AttributeSource,
    Entity,
    MaskRecord,
    Relation,
    RelationType,
    SceneGraph,
    SceneMeta,
    View,
)

__all__ = [
    "STORED_RELATION_TYPES",
    "Attribute",
    "AttributeSource",
    "Entity",
    "EntityNotFound",
    "GraphStore",
    "GraphStoreError",
    "InvalidSceneError",
    "MaskRecord",
    "RDFFormatError",
    "Relation",
    "RelationType",
    "SceneExistsError",
    "SceneGraph",
    "SceneMeta",
    "SceneNotFound",
    "SceneSummary",
    "SchemaVersionError",
    "SparqlArgumentError",
    "SparqlError",
    "SparqlForbiddenError",
    "SparqlFormatError",
    "SparqlResourceError",
    "SparqlRowLimitError",
    "SparqlSyntaxError",
    "SparqlTimeoutError",
    "StoreConnectionError",
    "StoreNotFoundError",
    "View",
    "as_url",
    "decode_labels",
    "open_store",
]
