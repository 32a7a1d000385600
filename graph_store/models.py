"""The store's tables (DESIGN §4), as SQLAlchemy 2.0 Core ``Table`` objects.

One database holds many scenes. Every per-scene table has the scene id in its primary
key and a foreign key to ``scenes`` with ``ON DELETE CASCADE``, so deleting a scene
removes everything it owns in one statement. Coordinates are double precision.

The schema is owned by Alembic (``migrations/``); :data:`metadata` is what ``alembic
check`` compares the migrated database against. The repository and the SQL executor read
and write through Core (``insert()`` executemany, ``select()``), so the tables are plain
Core: importing the ORM's declarative machinery cost every cold ``causalsplat ask`` about
0.15 CPU s and nothing used it. Columns are ``NOT NULL`` unless created by :func:`_null`.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import (
    JSON,
    BigInteger,
    Column,
    DateTime,
    Double,
    Enum,
    ForeignKey,
    ForeignKeyConstraint,
    Index,
    Integer,
    LargeBinary,
    MetaData,
    String,
    Table,
    Text,
    UniqueConstraint,
)
from sqlalchemy.types import TypeEngine

from graph_store.types import MAX_NAME_LENGTH, STORED_RELATION_TYPES, AttributeSource

NAMING_CONVENTION = {
    "ix": "ix_%(column_0_label)s",
    "uq": "uq_%(table_name)s_%(column_0_N_name)s",
    "ck": "ck_%(table_name)s_%(constraint_name)s",
    "fk": "fk_%(table_name)s_%(column_0_N_name)s_%(referred_table_name)s",
    "pk": "pk_%(table_name)s",
}

#: The one ``MetaData`` of the store: every table below, with the naming convention.
metadata = MetaData(naming_convention=NAMING_CONVENTION)

RELATION_TYPE_ENUM = Enum(
    *(t.value for t in STORED_RELATION_TYPES),
    name="relation_type",
    native_enum=False,
    create_constraint=True,
    length=32,
)
ATTRIBUTE_SOURCE_ENUM = Enum(
    *(s.value for s in AttributeSource),
    name="attribute_source",
    native_enum=False,
    create_constraint=True,
    length=32,
)


_Type = TypeEngine[Any] | type[TypeEngine[Any]]


def _col(name: str, type_: _Type, *args: Any, **kw: Any) -> Column[Any]:
    """A ``NOT NULL`` column."""
    return Column(name, type_, *args, nullable=False, **kw)


def _null(name: str, type_: _Type) -> Column[Any]:
    """A nullable column."""
    return Column(name, type_, nullable=True)


def _name(name: str, *args: Any, **kw: Any) -> Column[Any]:
    return _col(name, String(MAX_NAME_LENGTH), *args, **kw)


def _local_id(name: str, **kw: Any) -> Column[Any]:
    return _col(name, BigInteger, **kw)


def _coords(*names: str) -> list[Column[Any]]:
    return [_col(n, Double) for n in names]


def _scene_fk() -> Column[Any]:
    """Scene id column of a table owned directly by a scene."""
    return _name("scene_id", ForeignKey("scenes.id", ondelete="CASCADE"), primary_key=True)


def _scene_key() -> Column[Any]:
    """Scene id column of a table owned through an entity or view (cascades through them)."""
    return _name("scene_id", primary_key=True)


def _entity_fk(*local: str) -> ForeignKeyConstraint:
    return ForeignKeyConstraint(
        ["scene_id", *local], ["entities.scene_id", "entities.id"], ondelete="CASCADE"
    )


scenes = Table(
    "scenes",
    metadata,
    _name("id", primary_key=True),
    _null("name", Text),
    _name("units"),
    _col("up_axis", String(1)),
    _name("source"),
    _null("config_hash", String(MAX_NAME_LENGTH)),
    _col("provenance", JSON),
    _col("created_at", DateTime(timezone=True)),
    _col("entity_count", Integer),
    _col("relation_count", Integer),
)

entities = Table(
    "entities",
    metadata,
    _scene_fk(),
    _local_id("id", primary_key=True),
    _null("external_id", String(MAX_NAME_LENGTH)),
    _name("category"),
    _null("caption", Text),
    *_coords("cx", "cy", "cz", "min_x", "min_y", "min_z", "max_x", "max_y", "max_z"),
    _local_id("point_count"),
    _null("confidence", Double),
    UniqueConstraint("scene_id", "external_id"),
    Index("ix_entities_scene_category", "scene_id", "category"),
)

entity_attributes = Table(
    "entity_attributes",
    metadata,
    _scene_key(),
    _local_id("entity_id", primary_key=True),
    _name("key", primary_key=True),
    _col("value", Text, primary_key=True),
    _col("source", ATTRIBUTE_SOURCE_ENUM),
    _entity_fk("entity_id"),
    Index("ix_entity_attributes_scene_key_value", "scene_id", "key", "value"),
)

relations = Table(
    "relations",
    metadata,
    _scene_key(),
    _local_id("src", primary_key=True),
    _col("type", RELATION_TYPE_ENUM, primary_key=True),
    _local_id("dst", primary_key=True),
    _col("evidence", JSON),
    _entity_fk("src"),
    _entity_fk("dst"),
    Index("ix_relations_scene_dst_type", "scene_id", "dst", "type"),
)

views = Table(
    "views",
    metadata,
    _scene_fk(),
    _local_id("id", primary_key=True),
    _name("name"),
    _col("width", Integer),
    _col("height", Integer),
)

masks = Table(
    "masks",
    metadata,
    _scene_key(),
    _local_id("view_id", primary_key=True),
    _local_id("idx", primary_key=True),
    _null("entity_id", BigInteger),
    _null("label", Text),
    _null("score", Double),
    ForeignKeyConstraint(
        ["scene_id", "view_id"], ["views.scene_id", "views.id"], ondelete="CASCADE"
    ),
    _entity_fk("entity_id"),
    Index("ix_masks_scene_entity", "scene_id", "entity_id"),
)

#: Entity id per Gaussian of a scene, as one compressed little-endian array.
gaussian_labels = Table(
    "gaussian_labels",
    metadata,
    _scene_fk(),
    _col("count", BigInteger),
    _col("dtype", String(16)),
    _col("codec", String(16)),
    _col("sha256", String(64)),
    _col("data", LargeBinary),
)

#: Optional log of questions asked of a scene and the programs that answered them.
query_log = Table(
    "query_log",
    metadata,
    _col("id", Integer, primary_key=True, autoincrement=True),
    _name("scene_id", ForeignKey("scenes.id", ondelete="CASCADE"), index=True),
    _col("created_at", DateTime(timezone=True)),
    _null("text", Text),
    _col("program", JSON),
    _col("answer", JSON),
    _name("reasoner"),
)
