"""Exports of built scenes beyond RDF: a labelled 3DGS PLY, per-view answer masks, a figure.

The store keeps the graph and the entity of every Gaussian, not the Gaussians themselves:
the PLY and the cameras are read from the scene folder the scene was built from (its path
is in the scene's provenance, or given as ``source``), and the PLY's SHA-256 is checked
against the one recorded at build time so an edited folder is refused, not mislabelled.
"""

from causalsplat.export.figure import draw_scene_graph
from causalsplat.export.source import ExportError, source_folder
from causalsplat.export.splats import export_answer_masks, export_labelled_ply

__all__ = [
    "ExportError",
    "draw_scene_graph",
    "export_answer_masks",
    "export_labelled_ply",
    "source_folder",
]
