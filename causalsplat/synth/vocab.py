"""The small vocabulary of the synthetic rooms: categories, colours, materials, affordances.

Each category has a kind (structure, furniture or small object), a size range in metres
(x = width along a wall, y = depth, z = height), its default affordances, the materials and
typical colours it is drawn with, whether things can rest on its top, and (for small objects)
the categories it may rest on. The question templates used to generate commonsense and
affordance queries live here too, keyed by affordance.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

from causalsplat.colors import BASIC
from causalsplat.errors import CausalSplatError

Vec3 = tuple[float, float, float]


class UnknownCategoryError(CausalSplatError, KeyError):
    """A category name is not in the synthetic vocabulary."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else "unknown category"


class Kind(StrEnum):
    """What role a category plays in a room."""

    STRUCTURE = "structure"  # floor, wall: never falls; walls support nothing
    FURNITURE = "furniture"  # stands on the floor
    SMALL = "small"  # rests on furniture or on other small objects


#: Named colours (sRGB in [0, 1]): the palette entities' colours are named from, so a
#: generated room's colours read back as the names it was made with.
COLORS: dict[str, Vec3] = dict(BASIC)


@dataclass(frozen=True, slots=True)
class CategorySpec:
    """One category of the vocabulary.

    Attributes:
        name: category name (what mask labels and ``objects.json`` use).
        kind: structure, furniture or small object.
        size_min, size_max: box size range in metres (x along a wall, y depth, z height).
        affordances: default affordances (``sit``, ``wash hands``, ``place items``...).
        materials: materials it is drawn with (one is picked per instance).
        colors: typical colour names (keys of :data:`COLORS`).
        supports_items: things may be placed on its top surface.
        against_wall: furniture placed with its back to a wall.
        placed_on: small objects: the categories it may rest on.
    """

    name: str
    kind: Kind
    size_min: Vec3
    size_max: Vec3
    affordances: tuple[str, ...]
    materials: tuple[str, ...]
    colors: tuple[str, ...]
    supports_items: bool = False
    against_wall: bool = False
    placed_on: tuple[str, ...] = ()


_SURFACES = ("table", "desk", "counter", "cabinet", "nightstand", "shelf")


def _spec(
    name: str, kind: Kind, lo: Vec3, hi: Vec3, aff: str, mat: str, col: str, **kw: object
) -> CategorySpec:
    return CategorySpec(
        name=name,
        kind=kind,
        size_min=lo,
        size_max=hi,
        affordances=tuple(a for a in aff.split(",") if a),
        materials=tuple(mat.split(",")),
        colors=tuple(col.split(",")),
        **kw,  # type: ignore[arg-type]
    )


_F, _S = Kind.FURNITURE, Kind.SMALL
# fmt: off
_ALL: tuple[CategorySpec, ...] = (
    _spec("floor", Kind.STRUCTURE, (1, 1, 0.05), (1, 1, 0.05), "walk", "wood", "beige",
          supports_items=True),
    _spec("wall", Kind.STRUCTURE, (1, 0.1, 2.5), (1, 0.1, 2.5), "", "plaster", "white"),
    # furniture
    _spec("table", _F, (1.0, 0.7, 0.72), (1.5, 0.9, 0.76), "place items,dine", "wood,metal",
          "brown,white,black,beige", supports_items=True),
    _spec("desk", _F, (1.1, 0.6, 0.72), (1.5, 0.75, 0.76), "place items,work", "wood",
          "brown,white,black", supports_items=True, against_wall=True),
    _spec("chair", _F, (0.44, 0.44, 0.85), (0.52, 0.52, 0.95), "sit", "wood,plastic",
          "brown,black,red,blue,green"),
    _spec("stool", _F, (0.34, 0.34, 0.45), (0.40, 0.40, 0.62), "sit,place items", "wood,metal",
          "red,blue,yellow,green,black", supports_items=True),
    _spec("sofa", _F, (1.8, 0.85, 0.80), (2.2, 0.95, 0.90), "sit,lie down", "fabric",
          "gray,blue,green,beige", against_wall=True),
    _spec("bed", _F, (1.9, 1.4, 0.50), (2.1, 1.6, 0.60), "sleep,lie down,sit", "fabric",
          "white,blue,gray,pink", against_wall=True, supports_items=True),
    _spec("shelf", _F, (0.8, 0.30, 1.2), (1.2, 0.40, 1.8), "store items,place items", "wood",
          "brown,white,black", supports_items=True, against_wall=True),
    _spec("counter", _F, (1.2, 0.60, 0.90), (2.0, 0.65, 0.92), "place items,prepare food",
          "stone,wood", "white,gray,beige", supports_items=True, against_wall=True),
    _spec("cabinet", _F, (0.6, 0.45, 0.80), (1.0, 0.60, 0.90), "store items,place items",
          "wood", "brown,white,gray", supports_items=True, against_wall=True),
    _spec("nightstand", _F, (0.45, 0.40, 0.55), (0.50, 0.45, 0.60), "store items,place items",
          "wood", "brown,white", supports_items=True, against_wall=True),
    _spec("sink", _F, (0.50, 0.45, 0.85), (0.60, 0.50, 0.90), "wash hands,wash dishes",
          "ceramic", "white", supports_items=True, against_wall=True),
    _spec("stove", _F, (0.60, 0.60, 0.88), (0.62, 0.62, 0.92), "heat food,cook", "metal",
          "black,white,gray", supports_items=True, against_wall=True),
    _spec("fridge", _F, (0.70, 0.65, 1.70), (0.80, 0.75, 1.90), "store food,cool food",
          "metal", "white,gray", against_wall=True),
    # small objects
    _spec("book", _S, (0.15, 0.20, 0.03), (0.20, 0.27, 0.06), "read", "paper",
          "red,blue,green,yellow,orange,purple", supports_items=True,
          placed_on=(*_SURFACES, "bed", "box", "stool")),
    _spec("cup", _S, (0.07, 0.07, 0.09), (0.09, 0.09, 0.11), "drink", "ceramic",
          "white,red,blue,yellow,green", placed_on=(*_SURFACES, "book", "tray", "plate")),
    _spec("bottle", _S, (0.07, 0.07, 0.22), (0.08, 0.08, 0.28), "drink", "plastic,glass",
          "green,blue,teal", placed_on=("table", "desk", "counter", "tray", "board")),
    _spec("plate", _S, (0.20, 0.20, 0.02), (0.24, 0.24, 0.03), "eat,place items", "ceramic",
          "white,blue", supports_items=True, placed_on=("table", "counter", "tray")),
    _spec("bowl", _S, (0.14, 0.14, 0.06), (0.17, 0.17, 0.08), "eat", "ceramic",
          "white,orange,teal", placed_on=("table", "counter", "tray", "plate")),
    _spec("box", _S, (0.22, 0.20, 0.12), (0.35, 0.30, 0.20), "store items,place items",
          "cardboard", "brown,beige", supports_items=True,
          placed_on=("table", "desk", "shelf", "cabinet", "floor", "board")),
    _spec("tray", _S, (0.40, 0.30, 0.03), (0.50, 0.35, 0.04), "carry items,place items",
          "wood,plastic", "black,brown,white", supports_items=True,
          placed_on=("table", "counter")),
    _spec("board", _S, (0.90, 0.28, 0.03), (1.10, 0.32, 0.04), "place items", "wood",
          "beige,brown", supports_items=True, placed_on=("stool",)),
    _spec("laptop", _S, (0.32, 0.22, 0.02), (0.36, 0.25, 0.03), "work", "metal",
          "gray,black", placed_on=("desk", "table")),
    _spec("lamp", _S, (0.18, 0.18, 0.40), (0.22, 0.22, 0.50), "illuminate", "metal",
          "white,black,yellow", placed_on=("desk", "nightstand", "table", "shelf")),
    _spec("microwave", _S, (0.45, 0.35, 0.28), (0.52, 0.40, 0.32), "heat food", "metal",
          "white,black,gray", placed_on=("counter", "table")),
    _spec("pot", _S, (0.22, 0.22, 0.14), (0.28, 0.28, 0.18), "cook in", "metal",
          "gray,black,red", placed_on=("stove", "counter")),
    _spec("towel", _S, (0.30, 0.20, 0.04), (0.40, 0.25, 0.06), "dry hands", "fabric",
          "white,blue,pink,yellow", placed_on=("counter", "cabinet", "sink", "bed")),
    _spec("soap", _S, (0.08, 0.05, 0.04), (0.09, 0.06, 0.05), "wash hands", "soap",
          "pink,white,green", placed_on=("sink", "counter")),
    _spec("plant", _S, (0.18, 0.18, 0.30), (0.24, 0.24, 0.45), "decorate", "plant",
          "green", placed_on=("table", "shelf", "floor", "cabinet")),
    _spec("pillow", _S, (0.45, 0.32, 0.10), (0.55, 0.38, 0.14), "rest head", "fabric",
          "white,blue,pink,yellow", placed_on=("bed",)),
)
# fmt: on

#: Every category of the vocabulary, by name.
CATEGORIES: dict[str, CategorySpec] = {spec.name: spec for spec in _ALL}

#: Commonsense questions, by the affordance whose holders answer them.
COMMONSENSE_QUESTIONS: dict[str, str] = {
    "wash hands": "where can I wash my hands?",
    "dry hands": "what can I dry my hands with?",
    "heat food": "where can I heat up my food?",
    "store food": "where can I keep food cold?",
    "sleep": "where can I sleep?",
    "sit": "where can I sit down?",
    "drink": "what can I drink from?",
    "read": "what can I read?",
    "cook": "where can I cook a meal?",
    "cook in": "what can I cook soup in?",
    "dine": "where can I have dinner?",
    "illuminate": "what can light up the room?",
    "work": "what can I work on?",
    "eat": "what can I eat from?",
    "rest head": "what can I rest my head on?",
}

#: Affordance phrases ("something to sit on"), used as "<phrase> near <anchor>".
AFFORDANCE_PHRASES: dict[str, str] = {
    "sit": "something to sit on",
    "place items": "somewhere to put things",
    "store items": "somewhere to store things",
    "drink": "something to drink from",
    "read": "something to read",
    "lie down": "somewhere to lie down",
    "eat": "something to eat from",
    "illuminate": "something that gives light",
}


def get_category(name: str) -> CategorySpec:
    """The spec of category ``name``; raises :class:`UnknownCategoryError` when unknown."""
    try:
        return CATEGORIES[name]
    except KeyError:
        known = ", ".join(sorted(CATEGORIES))
        raise UnknownCategoryError(f"unknown category {name!r}; known: {known}") from None


def affordances_of(name: str) -> tuple[str, ...]:
    """Default affordances of category ``name``."""
    return get_category(name).affordances
