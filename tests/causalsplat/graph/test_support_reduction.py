"""An object rests on the top of a stack, and on every supporter that is not under another."""

from __future__ import annotations

from causalsplat.graph.config import EdgeConfig
from causalsplat.graph.edges import build_relations, build_relations_bruteforce
from graph_store import Entity, RelationType


def box(i: int, category: str, lo: tuple[float, ...], hi: tuple[float, ...]) -> Entity:
    centre = tuple((a + b) / 2 for a, b in zip(lo, hi, strict=True))
    return Entity(i, category, centre, lo, hi)  # type: ignore[arg-type]


FLOOR = box(0, "floor", (-2, -2, -0.02), (4, 4, 0.0))
TABLE = box(1, "table", (0, 0, 0), (1.2, 0.8, 0.74))
BOOK = box(2, "book", (0.4, 0.3, 0.74), (0.65, 0.48, 0.78))  # 4 cm thick
CUP = box(3, "cup", (0.48, 0.35, 0.78), (0.56, 0.43, 0.88))
STOOL_A = box(4, "stool", (2.0, 0, 0), (2.4, 0.4, 0.5))
STOOL_B = box(5, "stool", (2.6, 0, 0), (3.0, 0.4, 0.5))
BOARD = box(6, "board", (2.1, 0.05, 0.5), (2.9, 0.35, 0.52))
SCENE = (FLOOR, TABLE, BOOK, CUP, STOOL_A, STOOL_B, BOARD)


def supporters(relations: tuple, entity: int) -> set[int]:  # type: ignore[type-arg]
    return {r.dst for r in relations if r.type is RelationType.SUPPORTED_BY and r.src == entity}


def test_cup_on_book_on_table_rests_on_the_book_only() -> None:
    relations = build_relations(SCENE)
    assert supporters(relations, CUP.id) == {BOOK.id}
    assert supporters(relations, BOOK.id) == {TABLE.id}
    assert supporters(relations, TABLE.id) == {FLOOR.id}
    supported = {r.dst for r in relations if r.type is RelationType.SUPPORTS and r.src == TABLE.id}
    assert supported == {BOOK.id}  # the table no longer "supports" the cup


def test_board_across_two_stools_keeps_both_supporters() -> None:
    assert supporters(build_relations(SCENE), BOARD.id) == {STOOL_A.id, STOOL_B.id}


def test_without_reduction_every_touching_supporter_is_kept() -> None:
    config = EdgeConfig(reduce_support=False)
    assert supporters(build_relations(SCENE, config), CUP.id) == {BOOK.id, TABLE.id}


def test_reference_applies_the_same_filter() -> None:
    for config in (EdgeConfig(), EdgeConfig(reduce_support=False)):
        assert build_relations(SCENE, config) == build_relations_bruteforce(SCENE, config)
