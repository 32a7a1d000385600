"""Procedural room layouts: axis-aligned boxes with a ground-truth support structure.

Frame: metres, z up; the room interior is ``[0, Lx] x [0, Ly]`` with the floor's top at
``z = 0``; walls stand just outside the interior. Every entity is an axis-aligned box and
records the entities it rests on (``supporters``): furniture rests on the floor, small objects
on furniture or on other small objects, the board of the two-supporter motif on two stools.
A small object lies entirely inside its supporter's top; a bridging object covers at least
35 % of its own footprint on each supporter, so the Sr3D support rule (>= 30 % top-view
overlap) finds every GT support and no other.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from causalsplat.synth.config import SynthConfig
from causalsplat.synth.vocab import CATEGORIES, COLORS, CategorySpec, Kind, get_category

Vec3 = tuple[float, float, float]
Rect = tuple[float, float, float, float]  # x0, y0, x1, y1

_WALL_T = 0.1  # wall thickness, m
_FLOOR_T = 0.05
_FLOOR_GAP = 0.08  # clearance between floor footprints, m
_TOP_GAP = 0.02  # clearance between objects on one top, m
_MIN_BRIDGE_OVERLAP = 0.35


@dataclass(frozen=True, slots=True)
class SynthObject:
    """One entity of a synthetic room: an axis-aligned box.

    Attributes:
        id: entity id (also the external id in ``objects.json`` and the PLY's ``gt_instance``).
        category: vocabulary category name.
        kind: structure, furniture or small object.
        center, size: box centre and full extent (x, y, z), metres, world frame, z up.
        color: colour name; rgb: its RGB in [0, 1].
        material: material name.
        affordances: default affordances of the category.
        supporters: ids of the entities it rests on (empty for floor and walls).
    """

    id: int
    category: str
    kind: Kind
    center: Vec3
    size: Vec3
    color: str
    rgb: Vec3
    material: str
    affordances: tuple[str, ...]
    supporters: tuple[int, ...]

    @property
    def lo(self) -> np.ndarray:
        """(3,) float64 minimum corner."""
        return np.asarray(self.center) - 0.5 * np.asarray(self.size)

    @property
    def hi(self) -> np.ndarray:
        """(3,) float64 maximum corner."""
        return np.asarray(self.center) + 0.5 * np.asarray(self.size)

    @property
    def top(self) -> float:
        return float(self.center[2] + 0.5 * self.size[2])

    @property
    def footprint(self) -> Rect:
        lo, hi = self.lo, self.hi
        return (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))


@dataclass(frozen=True, slots=True)
class RoomLayout:
    """A generated room: its size and its entities (``objects[i].id == i``).

    Attributes:
        room_size: (Lx, Ly, H) interior size in metres.
        objects: every entity, floor first, then the walls, furniture and small objects.
    """

    room_size: Vec3
    objects: tuple[SynthObject, ...]

    def get(self, entity_id: int) -> SynthObject:
        return self.objects[entity_id]

    def children(self, entity_id: int) -> tuple[int, ...]:
        """Ids of the entities resting directly on ``entity_id``."""
        return tuple(o.id for o in self.objects if entity_id in o.supporters)

    def ids_of_kind(self, *kinds: Kind) -> tuple[int, ...]:
        return tuple(o.id for o in self.objects if o.kind in kinds)


def _overlap(a: Rect, b: Rect, gap: float = 0.0) -> bool:
    return a[0] < b[2] + gap and b[0] < a[2] + gap and a[1] < b[3] + gap and b[1] < a[3] + gap


def _area(r: Rect) -> float:
    return max(0.0, r[2] - r[0]) * max(0.0, r[3] - r[1])


def _intersection(a: Rect, b: Rect) -> float:
    return _area((max(a[0], b[0]), max(a[1], b[1]), min(a[2], b[2]), min(a[3], b[3])))


class _Builder:
    """Mutable state while a layout is generated (all randomness from one Generator)."""

    def __init__(self, cfg: SynthConfig, rng: np.random.Generator) -> None:
        self.cfg = cfg
        self.rng = rng
        self.lx, self.ly = (float(v) for v in cfg.room_size_m)
        self.h = float(cfg.wall_height_m)
        self.objects: list[SynthObject] = []
        self.floor_rects: list[Rect] = []

    # -- primitives ------------------------------------------------------------------
    def _color(self, spec: CategorySpec, avoid: set[str] | None = None) -> str:
        used = {o.color for o in self.objects if o.category == spec.name} | (avoid or set())
        fresh = [c for c in spec.colors if c not in used]
        pool = fresh or list(spec.colors)
        return pool[int(self.rng.integers(len(pool)))]

    def _size(self, spec: CategorySpec) -> Vec3:
        lo, hi = np.asarray(spec.size_min), np.asarray(spec.size_max)
        size = lo + self.rng.random(3) * (hi - lo)
        return (float(size[0]), float(size[1]), float(size[2]))

    def add(
        self,
        category: str,
        center: Vec3,
        size: Vec3,
        supporters: tuple[int, ...],
        color: str | None = None,
    ) -> int:
        spec = get_category(category)
        color = color or self._color(spec)
        material = spec.materials[int(self.rng.integers(len(spec.materials)))]
        obj = SynthObject(
            id=len(self.objects),
            category=category,
            kind=spec.kind,
            center=(float(center[0]), float(center[1]), float(center[2])),
            size=(float(size[0]), float(size[1]), float(size[2])),
            color=color,
            rgb=COLORS[color],
            material=material,
            affordances=spec.affordances,
            supporters=supporters,
        )
        self.objects.append(obj)
        return obj.id

    def structure(self) -> None:
        lx, ly, h, t = self.lx, self.ly, self.h, _WALL_T
        self.add("floor", (lx / 2, ly / 2, -_FLOOR_T / 2), (lx, ly, _FLOOR_T), (), "beige")
        walls = [
            ((lx / 2, -t / 2, h / 2), (lx + 2 * t, t, h)),
            ((lx + t / 2, ly / 2, h / 2), (t, ly, h)),
            ((lx / 2, ly + t / 2, h / 2), (lx + 2 * t, t, h)),
            ((-t / 2, ly / 2, h / 2), (t, ly, h)),
        ]
        for center, size in walls:
            self.add("wall", center, size, (), "white")

    # -- floor placement ---------------------------------------------------------------
    def _free_rect(self, fx: float, fy: float, wall: bool, swap: bool = True) -> Rect | None:
        lx, ly, rng = self.lx, self.ly, self.rng
        margin = 0.02 if wall else 0.3
        if wall:
            side = int(rng.integers(4))
            if side in (1, 3):
                fx, fy = fy, fx
            if fx > lx - 2 * margin or fy > ly - 2 * margin:
                return None
            x = rng.uniform(margin, lx - margin - fx)
            y = rng.uniform(margin, ly - margin - fy)
            x = {1: lx - fx, 3: 0.0}.get(side, x)
            y = {0: 0.0, 2: ly - fy}.get(side, y)
        else:
            if swap and rng.random() < 0.5:
                fx, fy = fy, fx
            if fx > lx - 2 * margin or fy > ly - 2 * margin:
                return None
            x = rng.uniform(margin, lx - margin - fx)
            y = rng.uniform(margin, ly - margin - fy)
        rect = (float(x), float(y), float(x + fx), float(y + fy))
        if any(_overlap(rect, r, _FLOOR_GAP) for r in self.floor_rects):
            return None
        return rect

    def place_on_floor(self, category: str, tries: int = 60) -> int | None:
        spec = get_category(category)
        size = self._size(spec)
        for _ in range(tries):
            rect = self._free_rect(size[0], size[1], spec.against_wall)
            if rect is not None:
                return self._add_floor_item(category, rect, size[2])
        return None

    def _add_floor_item(
        self, category: str, rect: Rect, height: float, color: str | None = None
    ) -> int:
        self.floor_rects.append(rect)
        center = ((rect[0] + rect[2]) / 2, (rect[1] + rect[3]) / 2, height / 2)
        size = (rect[2] - rect[0], rect[3] - rect[1], height)
        return self.add(category, center, size, (0,), color)

    def place_chair(self, tries: int = 60) -> int | None:
        spec = get_category("chair")
        tables = [o for o in self.objects if o.category in ("table", "desk")]
        size = self._size(spec)
        for attempt in range(tries):
            if not tables or attempt >= tries // 2:
                return self.place_on_floor("chair", tries - attempt)
            table = tables[int(self.rng.integers(len(tables)))]
            x0, y0, x1, y1 = table.footprint
            side = int(self.rng.integers(4))
            gap = 0.05
            if side in (0, 2):
                x = self.rng.uniform(x0, max(x0, x1 - size[0]))
                y = y0 - gap - size[1] if side == 0 else y1 + gap
            else:
                y = self.rng.uniform(y0, max(y0, y1 - size[1]))
                x = x0 - gap - size[0] if side == 3 else x1 + gap
            rect = (float(x), float(y), float(x + size[0]), float(y + size[1]))
            inside = rect[0] >= 0.02 and rect[1] >= 0.02
            inside = inside and rect[2] <= self.lx - 0.02 and rect[3] <= self.ly - 0.02
            others = [r for r in self.floor_rects if r != table.footprint]
            if inside and not any(_overlap(rect, r, 0.03) for r in others):
                return self._add_floor_item("chair", rect, size[2])
        return None

    # -- placement on tops ---------------------------------------------------------------
    def place_on(self, category: str, supporter: int, tries: int = 30) -> int | None:
        spec = get_category(category)
        if supporter == 0:
            return self.place_on_floor(category, tries)
        base = self.objects[supporter]
        sx, sy, sz = self._size(spec)
        bx0, by0, bx1, by1 = base.footprint
        siblings = [self.objects[c].footprint for c in self._children(supporter)]
        for _ in range(tries):
            fx, fy = (sy, sx) if self.rng.random() < 0.5 else (sx, sy)
            if fx > bx1 - bx0 - 0.02 or fy > by1 - by0 - 0.02:
                fx, fy = fy, fx
            if fx > bx1 - bx0 - 0.02 or fy > by1 - by0 - 0.02:
                return None
            x = self.rng.uniform(bx0 + 0.01, bx1 - 0.01 - fx)
            y = self.rng.uniform(by0 + 0.01, by1 - 0.01 - fy)
            rect = (float(x), float(y), float(x + fx), float(y + fy))
            if any(_overlap(rect, r, _TOP_GAP) for r in siblings):
                continue
            center = (x + fx / 2, y + fy / 2, base.top + sz / 2)
            return self.add(category, center, (fx, fy, sz), (supporter,))
        return None

    def _children(self, entity_id: int) -> list[int]:
        return [o.id for o in self.objects if entity_id in o.supporters]

    # -- motifs ---------------------------------------------------------------------------
    def stack_motif(self) -> bool:
        """A table with a book on it and a cup on the book (a support chain of depth 2)."""
        table = self.place_on_floor("table")
        if table is None:
            return False
        book = self.place_on("book", table)
        return book is not None and self.place_on("cup", book) is not None

    def bridge_motif(self, support: str, top: str, tries: int = 60) -> bool:
        """Two equal supporters side by side and one object resting on both."""
        sup, top_spec = get_category(support), get_category(top)
        w, d, h = self._size(sup)
        tw, td, th = self._size(top_spec)
        if support == "stool":
            gap = w * float(self.rng.uniform(0.3, 0.6))
            length, depth = 2 * w + gap - 0.04, min(td, d - 0.04)
        else:
            gap = float(self.rng.uniform(0.05, 0.15))
            length, depth = max(tw, gap / 0.25), min(td, d - 0.04)
        for _ in range(tries):
            along_x = bool(self.rng.random() < 0.5)
            gx, gy = (2 * w + gap, d) if along_x else (d, 2 * w + gap)
            rect = self._free_rect(gx, gy, wall=False, swap=False)
            if rect is None:
                continue
            self.floor_rects.append(rect)
            x0, y0 = rect[0], rect[1]
            parts = [(x0, y0, x0 + w, y0 + d), (x0 + w + gap, y0, x0 + 2 * w + gap, y0 + d)]
            if not along_x:
                parts = [(x0, y0, x0 + d, y0 + w), (x0, y0 + w + gap, x0 + d, y0 + 2 * w + gap)]
            first = self._color(sup)
            a = self._add_item_no_rect(support, parts[0], h, first)
            b = self._add_item_no_rect(support, parts[1], h, self._color(sup, {first}))
            cx, cy = (rect[0] + rect[2]) / 2, (rect[1] + rect[3]) / 2
            fx, fy = (length, depth) if along_x else (depth, length)
            self.add(top, (cx, cy, h + th / 2), (fx, fy, th), (a, b))
            self._check_bridge(len(self.objects) - 1)
            return True
        return False

    def _add_item_no_rect(self, category: str, rect: Rect, height: float, color: str) -> int:
        center = ((rect[0] + rect[2]) / 2, (rect[1] + rect[3]) / 2, height / 2)
        return self.add(
            category, center, (rect[2] - rect[0], rect[3] - rect[1], height), (0,), color
        )

    def _check_bridge(self, top_id: int) -> None:
        top = self.objects[top_id]
        for s in top.supporters:
            share = _intersection(top.footprint, self.objects[s].footprint) / _area(top.footprint)
            assert share >= _MIN_BRIDGE_OVERLAP, (top_id, s, share)


_FURNITURE_POOL = (
    "chair", "chair", "bed", "sofa", "desk", "shelf", "counter", "cabinet",
    "nightstand", "sink", "stove", "fridge", "table", "stool",
)  # fmt: skip


def generate_layout(cfg: SynthConfig, rng: np.random.Generator) -> RoomLayout:
    """A room for ``cfg``: structure, the two motifs, then random furniture and small objects.

    The stack motif (cup on book on table) and the board across two stools are always
    present; ``cfg.n_tray_bridges`` trays spanning two tables are added where they fit.
    """
    b = _Builder(cfg, rng)
    b.structure()
    b.stack_motif()
    b.bridge_motif("stool", "board")
    for _ in range(cfg.n_tray_bridges):
        b.bridge_motif("table", "tray")
    _fill_furniture(b, cfg.n_furniture)
    _fill_small(b, cfg.n_small)
    return RoomLayout(room_size=(b.lx, b.ly, b.h), objects=tuple(b.objects))


def _count(b: _Builder, kind: Kind) -> int:
    return sum(1 for o in b.objects if o.kind is kind)


def _fill_furniture(b: _Builder, target: int) -> None:
    pool = list(_FURNITURE_POOL)
    attempts = 0
    while _count(b, Kind.FURNITURE) < target and attempts < 6 * target + 20:
        if attempts % len(pool) == 0:
            order = [pool[i] for i in b.rng.permutation(len(pool))]
        category = order[attempts % len(pool)]
        attempts += 1
        if category == "chair":
            b.place_chair()
        else:
            b.place_on_floor(category)


def _fill_small(b: _Builder, target: int) -> None:
    small = sorted(n for n, s in CATEGORIES.items() if s.kind is Kind.SMALL and n != "board")
    attempts = 0
    while _count(b, Kind.SMALL) < target and attempts < 20 * target + 20:
        attempts += 1
        category = small[int(b.rng.integers(len(small)))]
        spec = CATEGORIES[category]
        hosts = [o.id for o in b.objects if o.category in spec.placed_on]
        if not hosts:
            continue
        b.place_on(category, hosts[int(b.rng.integers(len(hosts)))])
