"""Room layouts: counts, geometry, and a support structure that the geometry itself implies."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from causalsplat.synth import SynthConfig
from causalsplat.synth._layout import RoomLayout, SynthObject, generate_layout
from causalsplat.synth.config import InvalidSynthConfigError
from causalsplat.synth.generate import stream
from causalsplat.synth.support import fall_if_removed, support_closure, support_depth
from causalsplat.synth.vocab import CATEGORIES, COLORS, Kind, UnknownCategoryError, get_category

SEEDS = range(8)
#: Non-structure entity counts each preset must land in.
COUNTS = {"tiny": (6, 10), "small": (20, 30), "medium": (50, 70)}


def layout_of(size: str, seed: int) -> RoomLayout:
    cfg = SynthConfig.preset(size, seed=seed)
    return generate_layout(cfg, stream(seed, "layout"))


def _footprint_overlap(a: SynthObject, b: SynthObject) -> float:
    lo = np.maximum(a.lo[:2], b.lo[:2])
    hi = np.minimum(a.hi[:2], b.hi[:2])
    return float(np.prod(np.clip(hi - lo, 0, None)))


def supports_from_geometry(layout: RoomLayout, tol: float = 1e-5) -> dict[int, set[int]]:
    """The Sr3D rule, computed from the boxes alone: the upper's bottom touches the lower's top
    and the lower covers >= 30 % of the upper's footprint; walls support nothing."""
    out: dict[int, set[int]] = {}
    for up in layout.objects:
        if up.kind is Kind.STRUCTURE:
            continue
        area = float(up.size[0] * up.size[1])
        out[up.id] = {
            low.id
            for low in layout.objects
            if low.id != up.id
            and low.category != "wall"
            and abs(up.lo[2] - low.top) < tol
            and _footprint_overlap(up, low) >= 0.3 * area
        }
    return out


@pytest.mark.parametrize("size", list(COUNTS))
@pytest.mark.parametrize("seed", SEEDS)
def test_counts_and_geometry(size: str, seed: int) -> None:
    layout = layout_of(size, seed)
    lo_n, hi_n = COUNTS[size]
    things = [o for o in layout.objects if o.kind is not Kind.STRUCTURE]
    assert lo_n <= len(things) <= hi_n
    assert [o.id for o in layout.objects] == list(range(len(layout.objects)))
    assert [o.category for o in layout.objects[:5]] == ["floor"] + ["wall"] * 4
    lx, ly, h = layout.room_size
    for obj in things:
        assert np.all(obj.lo >= [-1e-9, -1e-9, -1e-9]) and np.all(
            obj.hi <= np.array([lx, ly, h]) + 1e-9
        )
        assert obj.rgb == COLORS[obj.color] and obj.color in CATEGORIES[obj.category].colors
        assert obj.affordances == CATEGORIES[obj.category].affordances
    # boxes never interpenetrate (touching faces are fine)
    for a, b in itertools.combinations(things, 2):
        overlap = np.minimum(a.hi, b.hi) - np.maximum(a.lo, b.lo)
        assert not np.all(overlap > 1e-6), (a, b)


@pytest.mark.parametrize("size", list(COUNTS))
@pytest.mark.parametrize("seed", SEEDS)
def test_gt_support_is_exactly_what_the_geometry_implies(size: str, seed: int) -> None:
    layout = layout_of(size, seed)
    derived = supports_from_geometry(layout)
    for obj in layout.objects:
        if obj.kind is Kind.STRUCTURE:
            assert obj.supporters == ()
            continue
        assert set(obj.supporters) == derived[obj.id], obj
        assert all(layout.get(s).category != "wall" for s in obj.supporters)
        if obj.kind is Kind.FURNITURE:
            assert obj.supporters == (0,)


@pytest.mark.parametrize("size", list(COUNTS))
@pytest.mark.parametrize("seed", SEEDS)
def test_motifs_present(size: str, seed: int) -> None:
    layout = layout_of(size, seed)
    two = [o for o in layout.objects if len(o.supporters) == 2]
    assert any(o.category == "board" for o in two)
    if size != "tiny":
        assert any(o.category == "tray" for o in two)
    for obj in two:  # each supporter carries >= 35 % of the footprint, both at one height
        a, b = (layout.get(s) for s in obj.supporters)
        assert a.top == pytest.approx(b.top)
        area = obj.size[0] * obj.size[1]
        assert min(_footprint_overlap(obj, a), _footprint_overlap(obj, b)) >= 0.35 * area
    depths = [support_depth(layout, o.id) for o in layout.objects]
    assert max(depths) >= 3  # cup (3) on book (2) on table (1) on the floor (0)
    cup = next(
        o for o in layout.objects if o.category == "cup" and support_depth(layout, o.id) == 3
    )
    book = layout.get(cup.supporters[0])
    assert book.category == "book" and layout.get(book.supporters[0]).category == "table"


def test_fall_if_removed_honours_two_supporters() -> None:
    layout = layout_of("tiny", 0)
    board = next(o for o in layout.objects if o.category == "board")
    a, b = board.supporters
    on_board = support_closure(layout, [board.id])
    assert board.id not in fall_if_removed(layout, [a])
    assert board.id not in fall_if_removed(layout, [b])
    assert fall_if_removed(layout, [a, b]) == {board.id} | on_board
    assert fall_if_removed(layout, [0]) == {
        o.id for o in layout.objects if o.kind is not Kind.STRUCTURE
    }
    assert fall_if_removed(layout, [1, 2, 3, 4]) == frozenset()  # walls hold nothing


def test_same_seed_same_layout_other_seed_other_layout() -> None:
    assert layout_of("small", 3) == layout_of("small", 3)
    assert layout_of("small", 3) != layout_of("small", 4)


def test_presets_and_validation() -> None:
    tiny = SynthConfig.preset("tiny", seed=7)
    assert (tiny.seed, tiny.width, tiny.height, tiny.n_views, tiny.n_gaussians) == (
        7,
        128,
        96,
        12,
        6000,
    )
    assert SynthConfig.preset("medium").n_views == 48
    with pytest.raises(InvalidSynthConfigError, match="unknown size 'huge'"):
        SynthConfig.preset("huge")
    with pytest.raises(InvalidSynthConfigError, match="unknown SynthConfig field"):
        SynthConfig.preset("tiny", colour="red")
    with pytest.raises(InvalidSynthConfigError, match="noise_strength"):
        SynthConfig.preset("tiny", noise_strength=-1.0)
    with pytest.raises(InvalidSynthConfigError, match="too small"):
        SynthConfig.preset("tiny", room_size_m=(1.0, 1.0))
    with pytest.raises(UnknownCategoryError, match="unknown category 'spaceship'"):
        get_category("spaceship")
