"""Store commands: ingest-objects, scenes, export, sparql, db upgrade."""

from __future__ import annotations
