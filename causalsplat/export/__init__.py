"""Exports of built scenes beyond RDF: the 3DGS PLY with its labels, answer masks, a figure.

The store keeps the graph and the entity of every Gaussian, not the Gaussians themselves:
the PLY and the cameras are read from the scene folder the scene was built from (its path
is in the scene's provenance, or given as ``source``), and the PLY's SHA-256 is checked
against the one recorded at build time so an edited folder is refused, not mislabelled.
"""

from causalsplat.export.figure import draw_scene_graph
from causalsplat.export.masks import export_answer_masks, overlay_mask
from causalsplat.export.source import ExportError, source_folder
from causalsplat.export.splats import (
    EMBEDDED_PROPERTY,
    PlyExport,
    export_labelled_ply,
    sidecar_paths,
)

__all__ = [
    "EMBEDDED_PROPERTY",
    "ExportError",
    "PlyExport",
    "draw_scene_graph",
    "export_answer_masks",
    "export_labelled_ply",
    "overlay_mask",
    "sidecar_paths",
    "source_folder",
]
