"""SQLAlchemy 2.0 models of the store (DESIGN §4).

One database holds many scenes. Every per-scene table has the scene id in its primary
key and a foreign key to ``scenes`` with ``ON DELETE CASCADE``, so deleting a scene
removes everything it owns in one statement. Coordinates are double precision.

The schema is owned by Alembic (``migrations/``); ``Base.metadata`` is what
``alembic check`` compares the migrated database against.
"""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Any, ClassVar, cast

from sqlalchemy import (
    JSON,
    BigInteger,
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
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column

from graph_store.types import MAX_NAME_LENGTH, STORED_RELATION_TYPES, AttributeSource

NAMING_CONVENTION = {
    "ix": "ix_%(column_0_label)s",
    "uq": "uq_%(table_name)s_%(column_0_N_name)s",
    "ck": "ck_%(table_name)s_%(constraint_name)s",
    "fk": "fk_%(table_name)s_%(column_0_N_name)s_%(referred_table_name)s",
    "pk": "pk_%(table_name)s",
}

Name = Annotated[str, mapped_column(String(MAX_NAME_LENGTH))]
LocalId = Annotated[int, mapped_column(BigInteger)]
Coord = Annotated[float, mapped_column(Double)]

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


class Base(DeclarativeBase):
    metadata = MetaData(naming_convention=NAMING_CONVENTION)
    type_annotation_map: ClassVar[dict[Any, Any]] = {
        dict[str, Any]: JSON,
        datetime: DateTime(timezone=True),
    }


class SceneRow(Base):
    __tablename__ = "scenes"

    id: Mapped[Name] = mapped_column(primary_key=True)
    name: Mapped[str | None] = mapped_column(Text)
    units: Mapped[Name]
    up_axis: Mapped[str] = mapped_column(String(1))
    source: Mapped[Name]
    config_hash: Mapped[str | None] = mapped_column(String(MAX_NAME_LENGTH))
    provenance: Mapped[dict[str, Any]]
    created_at: Mapped[datetime]
    entity_count: Mapped[int] = mapped_column(Integer)
    relation_count: Mapped[int] = mapped_column(Integer)


def _scene_fk() -> Any:
    """Scene id column of a table owned directly by a scene."""
    return mapped_column(
        String(MAX_NAME_LENGTH), ForeignKey("scenes.id", ondelete="CASCADE"), primary_key=True
    )


def _scene_key() -> Any:
    """Scene id column of a table owned through an entity or view (cascades through them)."""
    return mapped_column(String(MAX_NAME_LENGTH), primary_key=True)


class EntityRow(Base):
    __tablename__ = "entities"
    __table_args__ = (
        UniqueConstraint("scene_id", "external_id"),
        Index("ix_entities_scene_category", "scene_id", "category"),
    )

    scene_id: Mapped[str] = _scene_fk()
    id: Mapped[LocalId] = mapped_column(primary_key=True)
    external_id: Mapped[str | None] = mapped_column(String(MAX_NAME_LENGTH))
    category: Mapped[Name]
    caption: Mapped[str | None] = mapped_column(Text)
    cx: Mapped[Coord]
    cy: Mapped[Coord]
    cz: Mapped[Coord]
    min_x: Mapped[Coord]
    min_y: Mapped[Coord]
    min_z: Mapped[Coord]
    max_x: Mapped[Coord]
    max_y: Mapped[Coord]
    max_z: Mapped[Coord]
    point_count: Mapped[LocalId]
    confidence: Mapped[float | None] = mapped_column(Double)


def _entity_fk(*local: str) -> ForeignKeyConstraint:
    return ForeignKeyConstraint(
        ["scene_id", *local], ["entities.scene_id", "entities.id"], ondelete="CASCADE"
    )


class EntityAttributeRow(Base):
    __tablename__ = "entity_attributes"
    __table_args__ = (
        _entity_fk("entity_id"),
        Index("ix_entity_attributes_scene_key_value", "scene_id", "key", "value"),
    )

    scene_id: Mapped[str] = _scene_key()
    entity_id: Mapped[LocalId] = mapped_column(primary_key=True)
    key: Mapped[Name] = mapped_column(primary_key=True)
    value: Mapped[str] = mapped_column(Text, primary_key=True)
    source: Mapped[str] = mapped_column(ATTRIBUTE_SOURCE_ENUM)


class RelationRow(Base):
    __tablename__ = "relations"
    __table_args__ = (
        _entity_fk("src"),
        _entity_fk("dst"),
        Index("ix_relations_scene_dst_type", "scene_id", "dst", "type"),
    )

    scene_id: Mapped[str] = _scene_key()
    src: Mapped[LocalId] = mapped_column(primary_key=True)
    type: Mapped[str] = mapped_column(RELATION_TYPE_ENUM, primary_key=True)
    dst: Mapped[LocalId] = mapped_column(primary_key=True)
    evidence: Mapped[dict[str, Any]]


class ViewRow(Base):
    __tablename__ = "views"

    scene_id: Mapped[str] = _scene_fk()
    id: Mapped[LocalId] = mapped_column(primary_key=True)
    name: Mapped[Name]
    width: Mapped[int] = mapped_column(Integer)
    height: Mapped[int] = mapped_column(Integer)


class MaskRow(Base):
    __tablename__ = "masks"
    __table_args__ = (
        ForeignKeyConstraint(
            ["scene_id", "view_id"], ["views.scene_id", "views.id"], ondelete="CASCADE"
        ),
        _entity_fk("entity_id"),
        Index("ix_masks_scene_entity", "scene_id", "entity_id"),
    )

    scene_id: Mapped[str] = _scene_key()
    view_id: Mapped[LocalId] = mapped_column(primary_key=True)
    idx: Mapped[LocalId] = mapped_column(primary_key=True)
    entity_id: Mapped[int | None] = mapped_column(BigInteger)
    label: Mapped[str | None] = mapped_column(Text)
    score: Mapped[float | None] = mapped_column(Double)


class GaussianLabelsRow(Base):
    """Entity id per Gaussian of a scene, as one compressed little-endian array."""

    __tablename__ = "gaussian_labels"

    scene_id: Mapped[str] = _scene_fk()
    count: Mapped[int] = mapped_column(BigInteger)
    dtype: Mapped[str] = mapped_column(String(16))
    codec: Mapped[str] = mapped_column(String(16))
    sha256: Mapped[str] = mapped_column(String(64))
    data: Mapped[bytes] = mapped_column(LargeBinary)


class QueryLogRow(Base):
    """Optional log of questions asked of a scene and the programs that answered them."""

    __tablename__ = "query_log"

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    scene_id: Mapped[str] = mapped_column(
        String(MAX_NAME_LENGTH), ForeignKey("scenes.id", ondelete="CASCADE"), index=True
    )
    created_at: Mapped[datetime]
    text: Mapped[str | None] = mapped_column(Text)
    program: Mapped[dict[str, Any]]
    answer: Mapped[dict[str, Any]]
    reasoner: Mapped[Name]


def _table(model: type[Base]) -> Table:
    return cast(Table, model.__table__)


scenes = _table(SceneRow)
entities = _table(EntityRow)
entity_attributes = _table(EntityAttributeRow)
relations = _table(RelationRow)
views = _table(ViewRow)
masks = _table(MaskRow)
gaussian_labels = _table(GaussianLabelsRow)
query_log = _table(QueryLogRow)
