"""Initial schema: scenes, entities, attributes, relations, views, masks, labels, query log.

Revision ID: 0001
Revises: (none)
Create Date: 2026-11-21 13:52:26.925469
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0001"
down_revision: str | None = None
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    op.create_table(
        "scenes",
        sa.Column("id", sa.String(length=512), nullable=False),
        sa.Column("name", sa.Text(), nullable=True),
        sa.Column("units", sa.String(length=512), nullable=False),
        sa.Column("up_axis", sa.String(length=1), nullable=False),
        sa.Column("source", sa.String(length=512), nullable=False),
        sa.Column("config_hash", sa.String(length=512), nullable=True),
        sa.Column("provenance", sa.JSON(), nullable=False),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("entity_count", sa.Integer(), nullable=False),
        sa.Column("relation_count", sa.Integer(), nullable=False),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_scenes")),
    )
    op.create_table(
        "entities",
        sa.Column("scene_id", sa.String(length=512), nullable=False),
        sa.Column("id", sa.BigInteger(), nullable=False),
        sa.Column("external_id", sa.String(length=512), nullable=True),
        sa.Column("category", sa.String(length=512), nullable=False),
        sa.Column("caption", sa.Text(), nullable=True),
        sa.Column("cx", sa.Double(), nullable=False),
        sa.Column("cy", sa.Double(), nullable=False),
        sa.Column("cz", sa.Double(), nullable=False),
        sa.Column("min_x", sa.Double(), nullable=False),
        sa.Column("min_y", sa.Double(), nullable=False),
        sa.Column("min_z", sa.Double(), nullable=False),
        sa.Column("max_x", sa.Double(), nullable=False),
        sa.Column("max_y", sa.Double(), nullable=False),
        sa.Column("max_z", sa.Double(), nullable=False),
        sa.Column("point_count", sa.BigInteger(), nullable=False),
        sa.Column("confidence", sa.Double(), nullable=True),
        sa.ForeignKeyConstraint(
            ["scene_id"],
            ["scenes.id"],
            name=op.f("fk_entities_scene_id_scenes"),
            ondelete="CASCADE",
        ),
        sa.PrimaryKeyConstraint("scene_id", "id", name=op.f("pk_entities")),
        sa.UniqueConstraint(
            "scene_id", "external_id", name=op.f("uq_entities_scene_id_external_id")
        ),
    )
    with op.batch_alter_table("entities", schema=None) as batch_op:
        batch_op.create_index("ix_entities_scene_category", ["scene_id", "category"], unique=False)

    op.create_table(
        "gaussian_labels",
        sa.Column("scene_id", sa.String(length=512), nullable=False),
        sa.Column("count", sa.BigInteger(), nullable=False),
        sa.Column("dtype", sa.String(length=16), nullable=False),
        sa.Column("codec", sa.String(length=16), nullable=False),
        sa.Column("sha256", sa.String(length=64), nullable=False),
        sa.Column("data", sa.LargeBinary(), nullable=False),
        sa.ForeignKeyConstraint(
            ["scene_id"],
            ["scenes.id"],
            name=op.f("fk_gaussian_labels_scene_id_scenes"),
            ondelete="CASCADE",
        ),
        sa.PrimaryKeyConstraint("scene_id", name=op.f("pk_gaussian_labels")),
    )
    op.create_table(
        "query_log",
        sa.Column("id", sa.Integer(), autoincrement=True, nullable=False),
        sa.Column("scene_id", sa.String(length=512), nullable=False),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("text", sa.Text(), nullable=True),
        sa.Column("program", sa.JSON(), nullable=False),
        sa.Column("answer", sa.JSON(), nullable=False),
        sa.Column("reasoner", sa.String(length=512), nullable=False),
        sa.ForeignKeyConstraint(
            ["scene_id"],
            ["scenes.id"],
            name=op.f("fk_query_log_scene_id_scenes"),
            ondelete="CASCADE",
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_query_log")),
    )
    with op.batch_alter_table("query_log", schema=None) as batch_op:
        batch_op.create_index(batch_op.f("ix_query_log_scene_id"), ["scene_id"], unique=False)

    op.create_table(
        "views",
        sa.Column("scene_id", sa.String(length=512), nullable=False),
        sa.Column("id", sa.BigInteger(), nullable=False),
        sa.Column("name", sa.String(length=512), nullable=False),
        sa.Column("width", sa.Integer(), nullable=False),
        sa.Column("height", sa.Integer(), nullable=False),
        sa.ForeignKeyConstraint(
            ["scene_id"], ["scenes.id"], name=op.f("fk_views_scene_id_scenes"), ondelete="CASCADE"
        ),
        sa.PrimaryKeyConstraint("scene_id", "id", name=op.f("pk_views")),
    )
    op.create_table(
        "entity_attributes",
        sa.Column("scene_id", sa.String(length=512), nullable=False),
        sa.Column("entity_id", sa.BigInteger(), nullable=False),
        sa.Column("key", sa.String(length=512), nullable=False),
        sa.Column("value", sa.Text(), nullable=False),
        sa.Column(
            "source",
            sa.Enum(
                "input",
                "mask-vote",
                "vlm",
                "lexicon",
                "geometry",
                name="attribute_source",
                native_enum=False,
                create_constraint=True,
                length=32,
            ),
            nullable=False,
        ),
        sa.ForeignKeyConstraint(
            ["scene_id", "entity_id"],
            ["entities.scene_id", "entities.id"],
            name=op.f("fk_entity_attributes_scene_id_entity_id_entities"),
            ondelete="CASCADE",
        ),
        sa.PrimaryKeyConstraint(
            "scene_id", "entity_id", "key", "value", name=op.f("pk_entity_attributes")
        ),
    )
    with op.batch_alter_table("entity_attributes", schema=None) as batch_op:
        batch_op.create_index(
            "ix_entity_attributes_scene_key_value", ["scene_id", "key", "value"], unique=False
        )

    op.create_table(
        "masks",
        sa.Column("scene_id", sa.String(length=512), nullable=False),
        sa.Column("view_id", sa.BigInteger(), nullable=False),
        sa.Column("idx", sa.BigInteger(), nullable=False),
        sa.Column("entity_id", sa.BigInteger(), nullable=True),
        sa.Column("label", sa.Text(), nullable=True),
        sa.Column("score", sa.Double(), nullable=True),
        sa.ForeignKeyConstraint(
            ["scene_id", "entity_id"],
            ["entities.scene_id", "entities.id"],
            name=op.f("fk_masks_scene_id_entity_id_entities"),
            ondelete="CASCADE",
        ),
        sa.ForeignKeyConstraint(
            ["scene_id", "view_id"],
            ["views.scene_id", "views.id"],
            name=op.f("fk_masks_scene_id_view_id_views"),
            ondelete="CASCADE",
        ),
        sa.PrimaryKeyConstraint("scene_id", "view_id", "idx", name=op.f("pk_masks")),
    )
    with op.batch_alter_table("masks", schema=None) as batch_op:
        batch_op.create_index("ix_masks_scene_entity", ["scene_id", "entity_id"], unique=False)

    op.create_table(
        "relations",
        sa.Column("scene_id", sa.String(length=512), nullable=False),
        sa.Column("src", sa.BigInteger(), nullable=False),
        sa.Column(
            "type",
            sa.Enum(
                "above",
                "below",
                "supported_by",
                "supports",
                "inside",
                "contains",
                "near",
                "next_to",
                name="relation_type",
                native_enum=False,
                create_constraint=True,
                length=32,
            ),
            nullable=False,
        ),
        sa.Column("dst", sa.BigInteger(), nullable=False),
        sa.Column("evidence", sa.JSON(), nullable=False),
        sa.ForeignKeyConstraint(
            ["scene_id", "dst"],
            ["entities.scene_id", "entities.id"],
            name=op.f("fk_relations_scene_id_dst_entities"),
            ondelete="CASCADE",
        ),
        sa.ForeignKeyConstraint(
            ["scene_id", "src"],
            ["entities.scene_id", "entities.id"],
            name=op.f("fk_relations_scene_id_src_entities"),
            ondelete="CASCADE",
        ),
        sa.PrimaryKeyConstraint("scene_id", "src", "type", "dst", name=op.f("pk_relations")),
    )
    with op.batch_alter_table("relations", schema=None) as batch_op:
        batch_op.create_index(
            "ix_relations_scene_dst_type", ["scene_id", "dst", "type"], unique=False
        )


def downgrade() -> None:
    with op.batch_alter_table("relations", schema=None) as batch_op:
        batch_op.drop_index("ix_relations_scene_dst_type")

    op.drop_table("relations")
    with op.batch_alter_table("masks", schema=None) as batch_op:
        batch_op.drop_index("ix_masks_scene_entity")

    op.drop_table("masks")
    with op.batch_alter_table("entity_attributes", schema=None) as batch_op:
        batch_op.drop_index("ix_entity_attributes_scene_key_value")

    op.drop_table("entity_attributes")
    op.drop_table("views")
    with op.batch_alter_table("query_log", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_query_log_scene_id"))

    op.drop_table("query_log")
    op.drop_table("gaussian_labels")
    with op.batch_alter_table("entities", schema=None) as batch_op:
        batch_op.drop_index("ix_entities_scene_category")

    op.drop_table("entities")
    op.drop_table("scenes")
