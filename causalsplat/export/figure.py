"""A top-down figure of a scene graph: entity footprints, labels and edges by type (PNG).

The view looks down the scene's up axis; each entity is its bounding-box footprint,
structure (floor, walls, ceilings) in light grey, the rest outlined in a colour per
category with ``id category`` written at its centroid. Edges run between centroids in a
colour per relation type (one direction of each inverse pair; ``near`` is left out when
``next_to`` holds too); a legend names the colours. Needs pillow (``field`` extra).
"""

from __future__ import annotations

from pathlib import Path

from causalsplat.errors import MissingDependencyError
from causalsplat.export._palette import category_color
from causalsplat.export.source import ExportError
from graph_store import RelationType, SceneGraph

EDGE_COLORS: dict[RelationType, tuple[int, int, int]] = {
    RelationType.SUPPORTED_BY: (34, 139, 34),
    RelationType.ABOVE: (30, 90, 200),
    RelationType.INSIDE: (230, 120, 20),
    RelationType.NEXT_TO: (150, 150, 150),
    RelationType.NEAR: (205, 205, 205),
}
STRUCTURE = ("floor", "wall", "ceiling")
_AXES = {"z": (0, 1), "y": (0, 2), "x": (1, 2)}


def draw_scene_graph(graph: SceneGraph, out: str | Path, *, width: int = 1200) -> Path:
    """Draw ``graph`` top-down into the PNG ``out`` (module docstring); returns the path."""
    try:
        from PIL import Image, ImageDraw
    except ImportError as exc:  # pillow ships with the field extra
        raise MissingDependencyError(
            "the scene-graph figure needs pillow: pip install 'causalsplat[field]'"
        ) from exc
    if not graph.entities:
        raise ExportError(f"scene {graph.scene_id!r} has no entities to draw")
    a, b = _AXES.get(graph.meta.up_axis, (0, 1))
    xs = [v for e in graph.entities for v in (e.bbox_min[a], e.bbox_max[a])]
    ys = [v for e in graph.entities for v in (e.bbox_min[b], e.bbox_max[b])]
    x0, x1, y0, y1 = min(xs), max(xs), min(ys), max(ys)
    span = max(x1 - x0, y1 - y0, 1e-9)
    margin, legend = 40, 150
    scale = (width - 2 * margin) / max(x1 - x0, 1e-9 * span)
    height = round((y1 - y0) * scale) + 2 * margin + legend
    image = Image.new("RGB", (width, max(height, 2 * margin + legend + 10)), "white")
    draw = ImageDraw.Draw(image)

    def px(x: float, y: float) -> tuple[float, float]:  # y grows upwards in the scene
        return margin + (x - x0) * scale, margin + (y1 - y) * scale

    by_id = {e.id: e for e in graph.entities}
    for e in sorted(graph.entities, key=lambda e: e.category not in STRUCTURE):
        structural = e.category in STRUCTURE
        (ax, ay), (bx, by) = px(e.bbox_min[a], e.bbox_max[b]), px(e.bbox_max[a], e.bbox_min[b])
        color = (200, 200, 200) if structural else category_color(e.category)
        draw.rectangle([ax, ay, max(bx, ax + 1), max(by, ay + 1)], outline=color,
                       width=1 if structural else 2)  # fmt: skip
    shown = {(r.src, r.dst, r.type) for r in graph.relations if r.type in EDGE_COLORS}
    for src, dst, kind in sorted(shown, key=lambda t: list(EDGE_COLORS).index(t[2]), reverse=True):
        if kind is RelationType.NEAR and (src, dst, RelationType.NEXT_TO) in shown:
            continue
        if kind in (RelationType.NEAR, RelationType.NEXT_TO) and src > dst:
            continue
        s, d = by_id[src], by_id[dst]
        if s.category in STRUCTURE or d.category in STRUCTURE:
            continue
        ends = [px(s.centroid[a], s.centroid[b]), px(d.centroid[a], d.centroid[b])]
        draw.line(ends, fill=EDGE_COLORS[kind], width=1 if kind is RelationType.NEAR else 2)
    for e in graph.entities:
        if e.category in STRUCTURE:
            continue
        cx, cy = px(e.centroid[a], e.centroid[b])
        draw.ellipse([cx - 3, cy - 3, cx + 3, cy + 3], fill=category_color(e.category))
        draw.text((cx + 5, cy - 6), f"{e.id} {e.category}", fill=(20, 20, 20))
    top = image.height - legend + 20
    draw.text((margin, top - 16), f"{graph.scene_id}: {len(graph.entities)} entities, "
              f"{len(graph.relations)} relations (top view, {graph.meta.units})",
              fill=(0, 0, 0))  # fmt: skip
    for k, (kind, color) in enumerate(EDGE_COLORS.items()):
        y = top + 8 + 18 * k
        draw.line([margin, y, margin + 40, y], fill=color, width=3)
        draw.text((margin + 50, y - 6), kind.value, fill=(0, 0, 0))
    out = Path(out)
    image.save(out, format="PNG")
    return out
