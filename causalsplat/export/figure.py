"""A top-down figure of a scene graph: entity footprints, labels, edges by type, a scale bar.

The view looks down the scene's up axis; each entity is its bounding-box footprint,
structure (floor, walls, ceilings) in light grey, the rest outlined in a colour per
category with a dot at its centroid. Each object's ``id category`` label is placed where
it overlaps no other label and no dot (:func:`~causalsplat.export._placement.place_labels`),
with a leader line to its dot when it had to move away; labels that find no room in the
plot are listed in a strip under it, each with its leader line. Edges run between
centroids in a colour per relation type (one direction of each inverse pair; ``near`` is
left out when ``next_to`` holds too); a legend names the colours, and a scale bar gives a
round length in the scene's units. Needs pillow (``field`` extra).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from causalsplat.errors import MissingDependencyError
from causalsplat.export._palette import category_color
from causalsplat.export._placement import Box, nearest_point, place_labels, scale_bar_length
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
_MARGIN = 40
_LEGEND = 150
_PAD = 2  # pixels between a label's text and its box
_DOT = 3  # radius of an entity's dot

#: Width and height in pixels of a text as drawn.
Measure = Callable[[str], tuple[float, float]]


@dataclass(frozen=True, slots=True)
class PlacedLabel:
    """One entity's label: its text, its dot (``anchor``, pixels) and its box (pixels);
    ``leader``: a line joins the dot to the box."""

    entity_id: int
    text: str
    anchor: tuple[float, float]
    box: Box
    leader: bool


@dataclass(frozen=True, slots=True)
class ScaleBar:
    """``length`` scene units drawn from ``x0`` to ``x1`` at height ``y`` (pixels)."""

    length: float
    text: str
    x0: float
    x1: float
    y: float


@dataclass(frozen=True, slots=True)
class FigureLayout:
    """Where everything of :func:`draw_scene_graph` goes, in pixels (``y`` down).

    ``scale``: pixels per scene unit; scene point ``(u, v)`` (the two horizontal axes) is
    at ``(margin + (u - u0) * scale, margin + (v1 - v) * scale)``; ``plot_bottom``: the
    lowest pixel row of the plot (labels stay above it, except those listed under it).
    """

    width: int
    height: int
    scale: float
    u0: float
    v1: float
    plot_bottom: float
    legend_top: float
    labels: tuple[PlacedLabel, ...]
    scale_bar: ScaleBar

    def px(self, u: float, v: float) -> tuple[float, float]:
        return _MARGIN + (u - self.u0) * self.scale, _MARGIN + (self.v1 - v) * self.scale


def layout_scene_graph(graph: SceneGraph, measure: Measure, *, width: int = 1200) -> FigureLayout:
    """Place the plot, the labels and the scale bar of ``graph``'s figure (no drawing)."""
    if not graph.entities:
        raise ExportError(f"scene {graph.scene_id!r} has no entities to draw")
    a, b = _AXES.get(graph.meta.up_axis, (0, 1))
    us = [v for e in graph.entities for v in (e.bbox_min[a], e.bbox_max[a])]
    vs = [v for e in graph.entities for v in (e.bbox_min[b], e.bbox_max[b])]
    u0, u1, v0, v1 = min(us), max(us), min(vs), max(vs)
    scale = (width - 2 * _MARGIN) / max(u1 - u0, v1 - v0, 1e-12)
    plot_bottom = 2 * _MARGIN + (v1 - v0) * scale

    def px(u: float, v: float) -> tuple[float, float]:
        return _MARGIN + (u - u0) * scale, _MARGIN + (v1 - v) * scale

    objects = sorted((e for e in graph.entities if e.category not in STRUCTURE),
                     key=lambda e: (-e.centroid[b], e.centroid[a], e.id))  # fmt: skip
    anchors = [px(e.centroid[a], e.centroid[b]) for e in objects]
    texts = [f"{e.id} {e.category}" for e in objects]
    sizes = [(w + 2 * _PAD, h + 2 * _PAD) for w, h in map(measure, texts)]
    dots = [(x - _DOT, y - _DOT, x + _DOT, y + _DOT) for x, y in anchors]
    boxes = place_labels(anchors, sizes, (0, 0, width, plot_bottom), obstacles=dots)
    labels: list[PlacedLabel] = []
    overflow = []
    for e, anchor, text, size, box in zip(objects, anchors, texts, sizes, boxes, strict=True):
        if box is None:
            overflow.append((e, anchor, text, size))
            continue
        nx, ny = nearest_point(box, anchor)
        far = ((nx - anchor[0]) ** 2 + (ny - anchor[1]) ** 2) ** 0.5 > _DOT + 6
        labels.append(PlacedLabel(e.id, text, anchor, box, far))
    # labels with no room in the plot: rows under it, left to right
    x, y, row_h = float(_MARGIN), plot_bottom + 8, 0.0
    for e, anchor, text, (w, h) in overflow:
        if x + w > width - _MARGIN and x > _MARGIN:
            x, y, row_h = float(_MARGIN), y + row_h + 4, 0.0
        labels.append(PlacedLabel(e.id, text, anchor, (x, y, x + w, y + h), True))
        x, row_h = x + w + 8, max(row_h, h)
    legend_top = (y + row_h + 12) if overflow else plot_bottom
    height = round(legend_top + _LEGEND)
    length = scale_bar_length(0.25 * (width - 2 * _MARGIN) / scale)
    bar_y = legend_top + 30
    x1 = width - _MARGIN
    bar = ScaleBar(length, f"{length:g} {graph.meta.units}", x1 - length * scale, x1, bar_y)
    return FigureLayout(width, height, scale, u0, v1, plot_bottom, legend_top,
                        tuple(labels), bar)  # fmt: skip


def draw_scene_graph(graph: SceneGraph, out: str | Path, *, width: int = 1200) -> Path:
    """Draw ``graph`` top-down into the PNG ``out`` (module docstring); returns the path."""
    try:
        from PIL import Image, ImageDraw
    except ImportError as exc:  # pillow ships with the field extra
        raise MissingDependencyError(
            "the scene-graph figure needs pillow: pip install 'causalsplat[build]'"
        ) from exc
    if not graph.entities:
        raise ExportError(f"scene {graph.scene_id!r} has no entities to draw")
    probe = ImageDraw.Draw(Image.new("RGB", (1, 1)))

    def measure(text: str) -> tuple[float, float]:
        _, _, right, bottom = probe.textbbox((0, 0), text)
        return float(right), float(bottom)

    lay = layout_scene_graph(graph, measure, width=width)
    image = Image.new("RGB", (lay.width, lay.height), "white")
    draw = ImageDraw.Draw(image)
    a, b = _AXES.get(graph.meta.up_axis, (0, 1))
    by_id = {e.id: e for e in graph.entities}
    for e in sorted(graph.entities, key=lambda e: e.category not in STRUCTURE):
        structural = e.category in STRUCTURE
        (ax, ay), (bx, by) = (
            lay.px(e.bbox_min[a], e.bbox_max[b]),
            lay.px(e.bbox_max[a], e.bbox_min[b]),
        )
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
        ends = [lay.px(s.centroid[a], s.centroid[b]), lay.px(d.centroid[a], d.centroid[b])]
        draw.line(ends, fill=EDGE_COLORS[kind], width=1 if kind is RelationType.NEAR else 2)
    for label in lay.labels:
        if label.leader:
            draw.line([label.anchor, nearest_point(label.box, label.anchor)], fill=(90, 90, 90))
    for label in lay.labels:
        x, y = label.anchor
        color = category_color(by_id[label.entity_id].category)
        draw.ellipse([x - _DOT, y - _DOT, x + _DOT, y + _DOT], fill=color)
        x0, y0, x1, y1 = label.box
        draw.rectangle([x0, y0, x1 - 1, y1 - 1], fill=(255, 255, 255), outline=(225, 225, 225))
        draw.text((x0 + _PAD, y0 + _PAD), label.text, fill=(20, 20, 20))
    top = lay.legend_top + 20
    draw.text((_MARGIN, top - 16), f"{graph.scene_id}: {len(graph.entities)} entities, "
              f"{len(graph.relations)} relations (top view, {graph.meta.units})",
              fill=(0, 0, 0))  # fmt: skip
    for k, (kind, color) in enumerate(EDGE_COLORS.items()):
        y = top + 8 + 18 * k
        draw.line([_MARGIN, y, _MARGIN + 40, y], fill=color, width=3)
        draw.text((_MARGIN + 50, y - 6), kind.value, fill=(0, 0, 0))
    bar = lay.scale_bar
    draw.line([bar.x0, bar.y, bar.x1, bar.y], fill=(0, 0, 0), width=3)
    for x in (bar.x0, bar.x1):
        draw.line([x, bar.y - 5, x, bar.y + 5], fill=(0, 0, 0), width=1)
    text_w = probe.textbbox((0, 0), bar.text)[2]
    draw.text(((bar.x0 + bar.x1 - text_w) / 2, bar.y + 8), bar.text, fill=(0, 0, 0))
    out = Path(out)
    image.save(out, format="PNG")
    return out
