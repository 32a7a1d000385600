"""Error-against-run-time scatter plots as PNG bytes (pillow), Pareto front marked.

x: run time (log scale), y: error (linear, 0 at the bottom). Each point is labelled; the
points no other point beats on both axes are filled and joined by the front's line.
"""

from __future__ import annotations

import io
import math
from collections.abc import Sequence
from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class Point:
    seconds: float
    error: float
    label: str
    group: str


def pareto(points: Sequence[Point]) -> list[Point]:
    """The points not dominated (no other point is at least as fast and as accurate, and
    strictly better on one), fastest first."""
    front = [
        p for p in points
        if not any(q.seconds <= p.seconds and q.error <= p.error
                   and (q.seconds < p.seconds or q.error < p.error) for q in points)
    ]  # fmt: skip
    return sorted(front, key=lambda p: p.seconds)


def scatter_png(
    points: Sequence[Point], title: str, *, width: int = 900, height: int = 560
) -> bytes:
    from PIL import Image, ImageDraw

    left, right, top, bottom = 70, 30, 40, 60
    image = Image.new("RGB", (width, height), "white")
    draw = ImageDraw.Draw(image)
    xs = [math.log10(max(p.seconds, 1e-6)) for p in points]
    x0, x1 = min(xs), max(xs)
    if x1 - x0 < 1e-9:
        x0, x1 = x0 - 0.5, x1 + 0.5
    pad = 0.05 * (x1 - x0)
    x0, x1 = x0 - pad, x1 + pad
    y1 = max(max(p.error for p in points) * 1.1, 1e-9)

    def at(p: Point) -> tuple[float, float]:
        x = left + (math.log10(max(p.seconds, 1e-6)) - x0) / (x1 - x0) * (width - left - right)
        y = height - bottom - p.error / y1 * (height - top - bottom)
        return x, y

    draw.rectangle([left, top, width - right, height - bottom], outline=(0, 0, 0))
    for k in range(math.floor(x0), math.ceil(x1) + 1):
        for m in (1, 2, 5):
            v = math.log10(m) + k
            if x0 <= v <= x1:
                x = left + (v - x0) / (x1 - x0) * (width - left - right)
                draw.line([x, height - bottom, x, height - bottom + 5], fill=(0, 0, 0))
                draw.text((x - 10, height - bottom + 8), f"{10**v:g}", fill=(0, 0, 0))
    for k in range(6):
        v = y1 * k / 5
        y = height - bottom - v / y1 * (height - top - bottom)
        draw.line([left - 5, y, left, y], fill=(0, 0, 0))
        draw.text((8, y - 6), f"{v:.2f}", fill=(0, 0, 0))
    draw.text((width // 2 - 60, height - 25), "run time, s (log scale)", fill=(0, 0, 0))
    draw.text((left, 12), title, fill=(0, 0, 0))
    front = pareto(points)
    if len(front) > 1:
        draw.line([at(p) for p in front], fill=(200, 60, 60), width=2)
    groups = sorted({p.group for p in points})
    palette = [(31, 119, 180), (44, 160, 44), (148, 103, 189), (255, 127, 14), (140, 86, 75)]
    for p in points:
        x, y = at(p)
        color = palette[groups.index(p.group) % len(palette)]
        filled = p in front
        draw.ellipse([x - 5, y - 5, x + 5, y + 5], outline=color, width=2,
                     fill=color if filled else None)  # fmt: skip
        draw.text((x + 7, y - 7), p.label, fill=color)
    for k, g in enumerate(groups):
        y = top + 10 + 16 * k
        draw.ellipse([width - right - 150, y, width - right - 140, y + 10],
                     fill=palette[k % len(palette)])  # fmt: skip
        draw.text((width - right - 134, y - 1), g, fill=(0, 0, 0))
    buf = io.BytesIO()
    image.save(buf, format="PNG")
    return buf.getvalue()
