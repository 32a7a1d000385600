"""One display colour per category, shared by the figure and the PLY labels' sidecar."""

from __future__ import annotations

import hashlib


def category_color(category: str) -> tuple[int, int, int]:
    """An RGB colour (each channel 40..209) fixed by the category's name.

    >>> category_color("chair") == category_color("chair")
    True
    """
    h = hashlib.sha256(category.encode()).digest()
    return (40 + h[0] % 170, 40 + h[1] % 170, 40 + h[2] % 170)
