"""The top-down figure: labels never overlap each other or a dot, every object is labelled
once, and the scale bar is a round length drawn at the plot's scale."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image, ImageDraw

from causalsplat.export._placement import place_labels
from causalsplat.export.figure import FigureLayout, draw_scene_graph, layout_scene_graph
from graph_store import Entity, SceneGraph, SceneMeta

_PROBE = ImageDraw.Draw(Image.new("RGB", (1, 1)))


def _measure(text: str) -> tuple[float, float]:
    _, _, right, bottom = _PROBE.textbbox((0, 0), text)
    return float(right), float(bottom)


def _crowded(n: int, spread: float, seed: int = 0, units: str = "m") -> SceneGraph:
    """A floor and ``n`` small objects; ``spread``: side of the square their centres lie in."""
    rng = np.random.default_rng(seed)
    entities = [Entity(0, "floor", (2.0, 2.0, 0.0), (0.0, 0.0, -0.05), (4.0, 4.0, 0.0))]
    for k, (x, y) in enumerate(rng.uniform(2 - spread / 2, 2 + spread / 2, size=(n, 2)), 1):
        entities.append(Entity(k, f"thing number {k}", (x, y, 0.5), (x - 0.02, y - 0.02, 0.4),
                               (x + 0.02, y + 0.02, 0.6)))  # fmt: skip
    return SceneGraph(SceneMeta("crowded", units=units), tuple(entities), ())


def _disjoint(a: tuple[float, ...], b: tuple[float, ...]) -> bool:
    return a[2] <= b[0] or b[2] <= a[0] or a[3] <= b[1] or b[3] <= a[1]


def _check(lay: FigureLayout, graph: SceneGraph) -> None:
    objects = {e.id for e in graph.entities if e.category != "floor"}
    assert sorted(label.entity_id for label in lay.labels) == sorted(objects)
    for p, q in itertools.combinations(lay.labels, 2):
        assert _disjoint(p.box, q.box), (p, q)
    dots = [(x - 3, y - 3, x + 3, y + 3) for x, y in (label.anchor for label in lay.labels)]
    for label in lay.labels:
        x0, y0, x1, y1 = label.box
        assert x0 >= 0 and y0 >= 0 and x1 <= lay.width and y1 <= lay.legend_top
        assert all(_disjoint(label.box, dot) for dot in dots), label
        w, h = _measure(label.text)
        assert (x1 - x0, y1 - y0) == pytest.approx((w + 4, h + 4))


@pytest.mark.parametrize(("n", "spread", "width"), [(6, 3.0, 1200), (40, 0.6, 1200),
                                                     (150, 0.2, 300)])  # fmt: skip
def test_labels_never_overlap(n: int, spread: float, width: int) -> None:
    graph = _crowded(n, spread)
    lay = layout_scene_graph(graph, _measure, width=width)
    _check(lay, graph)
    moved = [label for label in lay.labels if label.leader]
    if n == 6:  # room for every label beside its dot
        assert not moved
    else:  # a crowd: some labels moved away, joined to their dots by leader lines
        assert moved
    if n == 150:  # more labels than the plot holds: the rest are listed under it
        assert any(label.box[1] >= lay.plot_bottom for label in lay.labels)


def test_scale_bar_is_a_round_length_at_the_plot_scale() -> None:
    graph = _crowded(5, 3.0, units="mm")
    lay = layout_scene_graph(graph, _measure)
    bar = lay.scale_bar
    assert bar.x1 - bar.x0 == pytest.approx(bar.length * lay.scale)
    mantissa = bar.length / 10 ** math.floor(math.log10(bar.length))
    assert round(mantissa, 9) in (1.0, 2.0, 5.0)
    plot_units = (lay.width - 80) / lay.scale  # 4 scene units of floor, in 1120 px
    assert 0.1 * plot_units < bar.length <= 0.25 * plot_units
    assert bar.text == "1 mm" and bar.y > lay.legend_top


def test_the_drawn_figure(tmp_path: Path) -> None:
    graph = _crowded(40, 0.6)
    out = draw_scene_graph(graph, tmp_path / "g.png")
    lay = layout_scene_graph(graph, _measure)
    image = np.asarray(Image.open(out).convert("RGB"))
    assert image.shape == (lay.height, lay.width, 3)
    bar = lay.scale_bar
    row = image[round(bar.y), round(bar.x0) + 2 : round(bar.x1) - 2]
    assert (row == 0).all()  # the bar is drawn black from end to end
    for label in lay.labels[:5]:  # each label's box is white behind its text
        x0, y0, x1, y1 = (round(v) for v in label.box)
        inside = image[y0 + 1 : y1 - 1, x0 + 1 : x1 - 1]
        assert (inside == 255).all(axis=2).mean() > 0.5 and (inside < 100).any()


def test_place_labels_leaves_out_what_does_not_fit() -> None:
    boxes = place_labels([(5, 5)] * 3, [(8, 8)] * 3, (0, 0, 30, 10), gap=0)
    assert boxes[0] is not None and boxes[1] is not None and boxes[2] is None
    assert _disjoint(boxes[0], boxes[1])
