"""Tokens of an instruction: lower-case words and clause marks, nothing else.

``tokenize("Facing the T.V., pick the chair that's left of it!")`` gives
``("facing", "the", "tv", ",", "pick", "the", "chair", "that", "is", "left", "of", "it")``.
Hyphens and slashes split words (``left-hand`` -> ``left hand``), ``'s`` after ``that`` /
``it`` / ``there`` / ``what`` / ``which`` becomes ``is``, other possessive ``'s`` is dropped,
and ``n't`` becomes ``not``. Commas, semicolons, colons and sentence ends are kept as ``,``
and ``.`` (clause boundaries); a question mark is kept as ``?``.
"""

from __future__ import annotations

import re
import unicodedata

_WORD = re.compile(r"[a-z0-9]+(?:'[a-z]+)?|[,;:.!?]")
_ABBREVIATIONS = {"t.v.": "tv", "t.v": "tv", "e.g.": "", "i.e.": "", "w/": "with "}
_IS_AFTER = frozenset({"that", "it", "there", "what", "which", "here", "who", "where", "he"})
NUMBER_WORDS: dict[str, int] = {
    "one": 1, "two": 2, "three": 3, "four": 4, "five": 5, "six": 6, "seven": 7, "eight": 8,
    "nine": 9, "ten": 10, "a": 1, "an": 1, "single": 1, "both": 2, "pair": 2, "couple": 2,
}  # fmt: skip
ORDINALS: dict[str, int] = {
    "first": 1, "1st": 1, "second": 2, "2nd": 2, "third": 3, "3rd": 3, "fourth": 4, "4th": 4,
    "fifth": 5, "5th": 5, "sixth": 6, "6th": 6, "seventh": 7, "7th": 7, "eighth": 8, "8th": 8,
}  # fmt: skip


def number_word(word: str) -> int:
    """The number a word says ("two", "3"); 0 for any other word."""
    return int(word) if word.isdigit() else NUMBER_WORDS.get(word, 0)


def normalise(text: str) -> str:
    """Unicode-folded, lower-case text with typographic quotes made plain."""
    text = unicodedata.normalize("NFKC", text).lower()
    text = text.replace("\u2019", "'").replace("\u2018", "'").replace("`", "'")
    for short, long in _ABBREVIATIONS.items():
        text = text.replace(short, long)
    return re.sub(r"[-/_]", " ", text)


def tokenize(text: str) -> tuple[str, ...]:
    """The tokens of ``text`` (module docstring)."""
    out: list[str] = []
    for raw in _WORD.findall(normalise(text)):
        if raw in ("!", ";", ":"):
            out.append("." if raw == "!" else ",")
            continue
        word, _, suffix = raw.partition("'")
        if suffix == "t" and word.endswith("n"):
            stem = {"won": "will", "can": "can", "don": "do", "isn": "is", "aren": "are"}.get(
                word, word[:-1]
            )
            out += [stem, "not"]
        elif suffix == "s":
            out.append(word)
            if word in _IS_AFTER:
                out.append("is")
        elif suffix in ("re", "m"):
            out += [word, "are" if suffix == "re" else "am"]
        elif suffix in ("ll", "d", "ve"):
            out.append(word)
        else:
            out.append(word)
    return tuple(t for t in out if t)


def sentences(tokens: tuple[str, ...]) -> list[tuple[str, ...]]:
    """``tokens`` split at sentence ends (``.`` and ``?``), empty parts dropped."""
    out: list[tuple[str, ...]] = []
    current: list[str] = []
    for t in tokens:
        if t in (".", "?"):
            if current:
                out.append(tuple(current))
            current = []
        else:
            current.append(t)
    if current:
        out.append(tuple(current))
    return out
