"""Colour in a perceptual space: an object's mean colour, its names, and colour words.

An object's colour is one sRGB triple (its Gaussians' opacity-weighted mean base colour, or
an objects file's ``rgb``), stored with the entity as ``rgb`` = ``#rrggbb``. Names come from
its distance in CIELAB (D65) to the prototypes of the basic colour terms (:data:`BASIC`:
the eleven of Berlin and Kay plus ``beige`` and ``teal``): every term within
:data:`NAME_MARGIN` of the nearest is a name of it, since lighting moves a measured colour
(a white fridge in a dim scan measures grey; it is both). Lightness weighs half as much as
the two chroma axes (shading moves mostly L*).

A colour word ("navy", "light blue", "grey", "golden") is matched by the same distance:
its prototype (:data:`WORDS`: standard sRGB values of common colour names; ``light`` and
``dark`` mix in white or black by :data:`SHADE_MIX`) against the object's colour, never by
comparing strings. Words with no hue of their own (``wooden``, ``metal``) are not colours.

>>> names_of((0.93, 0.93, 0.91))
('white',)
>>> names_of((0.55, 0.42, 0.30))
('brown', 'beige')
>>> word_distance("navy", hex_to_rgb("#1f2a5a")) < word_distance("red", hex_to_rgb("#1f2a5a"))
True
>>> is_color_word("grey"), is_color_word("light"), is_color_word("wooden")
(True, False, False)
"""

from __future__ import annotations

import re
from collections.abc import Sequence

import numpy as np

#: Basic colour term -> prototype sRGB in [0, 1].
BASIC: dict[str, tuple[float, float, float]] = {
    "red": (0.80, 0.17, 0.15),
    "orange": (0.92, 0.52, 0.15),
    "yellow": (0.93, 0.83, 0.22),
    "green": (0.25, 0.62, 0.28),
    "teal": (0.15, 0.55, 0.56),
    "blue": (0.20, 0.35, 0.80),
    "purple": (0.52, 0.30, 0.68),
    "pink": (0.92, 0.55, 0.68),
    "white": (0.92, 0.92, 0.90),
    "gray": (0.55, 0.55, 0.57),
    "black": (0.12, 0.12, 0.13),
    "brown": (0.48, 0.31, 0.18),
    "beige": (0.85, 0.77, 0.60),
}

#: Other colour words -> sRGB in [0, 1] (standard web colour values, spelling variants).
WORDS: dict[str, tuple[float, float, float]] = {
    **BASIC,
    "grey": BASIC["gray"],
    "silver": (0.75, 0.75, 0.75),
    "navy": (0.0, 0.0, 0.50),
    "maroon": (0.50, 0.0, 0.0),
    "burgundy": (0.50, 0.0, 0.13),
    "crimson": (0.86, 0.08, 0.24),
    "scarlet": (1.0, 0.14, 0.0),
    "tan": (0.82, 0.71, 0.55),
    "cream": (1.0, 0.99, 0.82),
    "ivory": (1.0, 1.0, 0.94),
    "khaki": (0.76, 0.69, 0.57),
    "gold": (0.83, 0.69, 0.22),
    "golden": (0.83, 0.69, 0.22),
    "olive": (0.50, 0.50, 0.0),
    "turquoise": (0.25, 0.88, 0.82),
    "cyan": (0.0, 0.75, 0.80),
    "aqua": (0.0, 0.75, 0.80),
    "violet": (0.56, 0.0, 1.0),
    "lavender": (0.71, 0.49, 0.86),
    "magenta": (0.80, 0.0, 0.80),
    "lilac": (0.78, 0.64, 0.78),
    "peach": (1.0, 0.80, 0.64),
    "salmon": (0.98, 0.50, 0.45),
    "charcoal": (0.21, 0.27, 0.31),
    "chocolate": (0.48, 0.25, 0.10),
    "mahogany": (0.45, 0.18, 0.10),
    "walnut": (0.37, 0.25, 0.17),
    "copper": (0.72, 0.45, 0.20),
    "bronze": (0.80, 0.50, 0.20),
    "mint": (0.60, 0.90, 0.70),
    "lime": (0.55, 0.85, 0.20),
    "rust": (0.72, 0.25, 0.05),
    "off white": (0.96, 0.95, 0.90),
    "blonde": (0.90, 0.80, 0.55),
    "tangerine": (0.95, 0.52, 0.0),
}
#: Adjectival forms -> the colour word ("reddish", "greyish", "bluish").
_SUFFIXED = re.compile(r"^([a-z]+?)(?:ish|dish|-ish)$")
#: How much white (``light``) or black (``dark``) is mixed into a word's prototype.
SHADE_MIX = 0.45
#: Words that make a colour lighter or darker ("light blue", "dark brown"); said of a
#: thing alone ("the dark couch", "a light-coloured table") they name its lightness.
SHADES: dict[str, str] = {
    "light": "light", "lighter": "light", "lightest": "light", "pale": "light",
    "pastel": "light", "dark": "dark", "darker": "dark", "darkest": "dark", "deep": "dark",
}  # fmt: skip
#: A term names a colour when it is within this much (weighted Delta E) of the nearest term.
NAME_MARGIN = 12.0
_WEIGHT = np.array([0.5, 1.0, 1.0])


def srgb_to_lab(rgb: np.ndarray | Sequence[float]) -> np.ndarray:
    """(..., 3) sRGB in [0, 1] to CIELAB (D65), float64.

    >>> [round(abs(v), 3) for v in srgb_to_lab([1.0, 1.0, 1.0]).tolist()]
    [100.0, 0.0, 0.0]
    """
    c = np.clip(np.asarray(rgb, dtype=np.float64), 0.0, 1.0)
    lin = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    m = np.array(
        [[0.4124564, 0.3575761, 0.1804375],
         [0.2126729, 0.7151522, 0.0721750],
         [0.0193339, 0.1191920, 0.9503041]]
    )  # fmt: skip
    xyz = lin @ m.T / np.array([0.95047, 1.0, 1.08883])
    eps, kappa = 216 / 24389, 24389 / 27
    f = np.where(xyz > eps, np.cbrt(xyz), (kappa * xyz + 16) / 116)
    return np.stack(
        [116 * f[..., 1] - 16, 500 * (f[..., 0] - f[..., 1]), 200 * (f[..., 1] - f[..., 2])],
        axis=-1,
    )


_BASIC_NAMES = tuple(BASIC)
_BASIC_LAB = srgb_to_lab(np.array([BASIC[n] for n in _BASIC_NAMES]))


def distance(lab_a: np.ndarray, lab_b: np.ndarray) -> np.ndarray:
    """Weighted Euclidean distance in CIELAB (lightness at half weight), broadcast."""
    d = (np.asarray(lab_a, dtype=np.float64) - np.asarray(lab_b, dtype=np.float64)) * _WEIGHT
    return np.sqrt((d**2).sum(axis=-1))


def names_of(rgb: Sequence[float] | np.ndarray, margin: float = NAME_MARGIN) -> tuple[str, ...]:
    """The basic terms naming an sRGB colour: the nearest first, then every term within
    ``margin`` of it, nearest first."""
    d = distance(_BASIC_LAB, srgb_to_lab(rgb))
    order = np.argsort(d, kind="stable")
    best = d[order[0]]
    return tuple(_BASIC_NAMES[i] for i in order if d[i] <= best + margin)


def mean_color(colors: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray | None:
    """The weighted mean of (K, 3) sRGB colours (``None`` when K = 0 or no weight)."""
    colors = np.asarray(colors, dtype=np.float64).reshape(-1, 3)
    if colors.shape[0] == 0:
        return None
    w = np.ones(len(colors)) if weights is None else np.asarray(weights, dtype=np.float64)
    total = float(w.sum())
    if not np.isfinite(total) or total <= 0:
        return None
    return np.clip((colors * w[:, None]).sum(axis=0) / total, 0.0, 1.0)


def rgb_to_hex(rgb: Sequence[float] | np.ndarray) -> str:
    """sRGB in [0, 1] -> ``#rrggbb``.

    >>> rgb_to_hex((1.0, 0.5, 0.0))
    '#ff8000'
    """
    r, g, b = (round(float(np.clip(v, 0.0, 1.0)) * 255) for v in rgb)
    return f"#{r:02x}{g:02x}{b:02x}"


_HEX = re.compile(r"^#[0-9a-f]{6}$")


def hex_to_rgb(text: str) -> tuple[float, float, float] | None:
    """``#rrggbb`` -> sRGB in [0, 1]; ``None`` for any other string."""
    text = text.strip().lower()
    if not _HEX.match(text):
        return None
    return tuple(int(text[i : i + 2], 16) / 255 for i in (1, 3, 5))  # type: ignore[return-value]


def color_word(word: str) -> str:
    """The colour word of :data:`WORDS` that ``word`` is a form of ("greyish" -> "grey");
    ``KeyError`` when it names no colour."""
    name = _word(word)
    if name is None:
        raise KeyError(word)
    return name


def nearest_term_distance(rgb: Sequence[float] | np.ndarray) -> float:
    """Distance from an sRGB colour to the nearest basic term's prototype."""
    return float(distance(_BASIC_LAB, srgb_to_lab(rgb)).min())


def _word(word: str) -> str | None:
    word = word.lower().strip()
    if word in WORDS:
        return word
    m = _SUFFIXED.match(word)
    if m is not None:
        for stem in (m.group(1), m.group(1) + "e"):
            if stem in WORDS:
                return stem
    return None


def is_color_word(word: str) -> bool:
    """Whether ``word`` names a colour (a basic term, another colour word, or its -ish form)."""
    return _word(word) is not None


def colour_phrase(text: str) -> tuple[str | None, str | None] | None:
    """A colour phrase as (colour word, shade): "dark brown" -> ("brown", "dark"), "navy"
    -> ("navy", None), "pale" -> (None, "light"); ``None`` when ``text`` is no colour
    phrase.

    >>> colour_phrase("light blue"), colour_phrase("greyish"), colour_phrase("dark")
    (('blue', 'light'), ('grey', None), (None, 'dark'))
    >>> colour_phrase("wooden") is None
    True
    """
    words = text.lower().split()
    shade = SHADES.get(words[0]) if words else None
    if shade is not None:
        words = words[1:]
    if not words:
        return (None, shade) if shade is not None else None
    name = _word(words[0]) if len(words) == 1 else None
    return None if name is None else (name, shade)


def lightness(rgb: Sequence[float] | np.ndarray) -> float:
    """CIELAB L* (0 black to 100 white) of an sRGB colour."""
    return float(srgb_to_lab(rgb)[0])


def word_lab(word: str, shade: str | None = None) -> np.ndarray | None:
    """The CIELAB prototype of a colour word, made lighter or darker by ``shade``
    (``"light"``, ``"dark"``, or ``None``); ``None`` when the word names no colour."""
    name = _word(word)
    if name is None:
        return None
    rgb = np.asarray(WORDS[name], dtype=np.float64)
    if shade in ("light", "pale", "bright"):
        rgb = rgb + (1.0 - rgb) * SHADE_MIX  # a tint: mixed with white
    elif shade in ("dark", "deep"):
        rgb = rgb * (1.0 - SHADE_MIX)  # a shade: mixed with black
    return srgb_to_lab(rgb)


def word_distance(word: str, rgb: Sequence[float] | np.ndarray, shade: str | None = None) -> float:
    """Perceptual distance from a colour word's prototype to an sRGB colour (``inf`` when
    the word names no colour)."""
    lab = word_lab(word, shade)
    if lab is None:
        return float("inf")
    return float(distance(lab, srgb_to_lab(rgb)))


def word_fits(word: str, rgb: Sequence[float] | np.ndarray, shade: str | None = None,
              margin: float = NAME_MARGIN) -> bool:  # fmt: skip
    """Whether a colour word may name an sRGB colour: its prototype is no farther than
    ``margin`` beyond the nearest basic term's (the rule :func:`names_of` names by)."""
    return word_distance(word, rgb, shade) <= nearest_term_distance(rgb) + margin
