"""Finding (and checking) the scene folder a stored scene was built from."""

from __future__ import annotations

import hashlib
from pathlib import Path

from causalsplat.errors import CausalSplatError
from graph_store import SceneGraph

#: Provenance key under which a build records its scene folder.
SOURCE_KEY = "source_dir"


class ExportError(CausalSplatError):
    """An export cannot be made (no source folder, a changed PLY, no labels...)."""


def source_folder(graph: SceneGraph, source: str | Path | None = None) -> Path:
    """The scene folder of a built scene: ``source`` when given, else the recorded one."""
    prov = dict(graph.meta.provenance)
    if source is None:
        if SOURCE_KEY not in prov:
            if graph.meta.source == "build":
                raise ExportError(
                    f"scene {graph.scene_id!r} does not record its scene folder; pass the "
                    "folder it was built from (CLI: --source DIR)"
                )
            raise ExportError(
                f"scene {graph.scene_id!r} was not built from a scene folder (source "
                f"{graph.meta.source!r}); only built scenes have Gaussians to export"
            )
        source = prov[SOURCE_KEY]
    root = Path(source)
    if not root.is_dir():
        raise ExportError(
            f"scene {graph.scene_id!r}: its scene folder {root} is not there (pass --source DIR)"
        )
    return root


def check_hash(graph: SceneGraph, root: Path, path: Path) -> None:
    """Refuse a file whose SHA-256 differs from the one recorded when the scene was built."""
    prov = dict(graph.meta.provenance)
    key = path.relative_to(root).as_posix()
    recorded = prov.get(key)
    if recorded is None:
        return
    digest = hashlib.sha256(path.read_bytes()).hexdigest()
    if digest != recorded:
        raise ExportError(
            f"{path} changed since scene {graph.scene_id!r} was built (SHA-256 {digest[:12]}, "
            f"recorded {recorded[:12]}); rebuild the scene or pass the original folder"
        )
