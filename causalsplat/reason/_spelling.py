"""Misspelt words of an instruction, read as the scene word they were meant to be.

People type fast: "the chiar by the dsk", "the bronw door", "the trashcan". A token is
corrected only when it is not an English word (:meth:`Lexicon.is_word
<causalsplat.reason.lexicon.Lexicon.is_word>`, WordNet in every part of speech and
inflection) nor a word of the grammar, and exactly one word of the *correction
vocabulary* lies one edit away from it (a letter substituted, inserted or dropped, or two
neighbours swapped; both words of at least :data:`MIN_LENGTH` letters). The vocabulary is
what a reference turns on: the words of the scene's category names, colour names and the
grammar's side and size words. A run-together name of a scene category ("trashcan" for
``trash can``) is split into its words. Real words are never changed ("hair" stays hair,
"ajar" stays ajar), so a correction cannot turn a well-formed sentence into another.

>>> correct(("the", "chiar", "by", "the", "bronw", "dsk"), frozenset({"chair", "brown", "desk"}),
...         lambda w: w in {"the", "by"})
(('the', 'chair', 'by', 'the', 'brown', 'dsk'), (('chiar', 'chair'), ('bronw', 'brown')))
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

#: Shortest word corrected, and shortest word corrected to: in three letters one edit
#: reaches too many words ("dsk" could be desk or disk).
MIN_LENGTH = 4


def one_edit_apart(a: str, b: str) -> bool:
    """Whether ``a`` and ``b`` differ by exactly one substitution, insertion, deletion or
    swap of two neighbouring letters (optimal string alignment distance 1).

    >>> one_edit_apart("tabel", "table"), one_edit_apart("chair", "chairs")
    (True, True)
    >>> one_edit_apart("chair", "chair"), one_edit_apart("bed", "red"), one_edit_apart("ab", "ba")
    (False, True, True)
    >>> one_edit_apart("desk", "dusky")
    False
    """
    if a == b or abs(len(a) - len(b)) > 1:
        return False
    if len(a) > len(b):
        a, b = b, a
    i = 0
    while i < len(a) and a[i] == b[i]:
        i += 1
    if len(a) < len(b):  # one letter inserted into a at i
        return a[i:] == b[i + 1 :]
    if a[i + 1 :] == b[i + 1 :]:  # substituted
        return True
    return i + 1 < len(a) and a[i] == b[i + 1] and a[i + 1] == b[i] and a[i + 2 :] == b[i + 2 :]


def correct(
    tokens: tuple[str, ...],
    vocabulary: frozenset[str],
    is_word: Callable[[str], bool],
    compounds: Iterable[str] = (),
) -> tuple[tuple[str, ...], tuple[tuple[str, str], ...]]:
    """``tokens`` with misspelt words corrected (module docstring), and the corrections
    made as ``(written, read)`` pairs. ``compounds``: multi-word names whose run-together
    spelling is split ("trash can")."""
    joined = {c.replace(" ", ""): tuple(c.split()) for c in compounds if " " in c}
    out: list[str] = []
    made: list[tuple[str, str]] = []
    for t in tokens:
        if not t.isalpha() or t in vocabulary:
            out.append(t)
            continue
        if t in joined or (t.endswith("s") and t[:-1] in joined):
            words = joined.get(t) or (*joined[t[:-1]][:-1], joined[t[:-1]][-1] + "s")
            out += words
            made.append((t, " ".join(words)))
            continue
        if len(t) < MIN_LENGTH or is_word(t):
            out.append(t)
            continue
        near = {v for v in vocabulary if len(v) >= MIN_LENGTH and one_edit_apart(t, v)}
        if t.endswith("s") and not near:
            near = {v + "s" for v in vocabulary
                    if len(v) >= MIN_LENGTH and one_edit_apart(t[:-1], v)}  # fmt: skip
        if len(near) == 1:
            (word,) = near
            out.append(word)
            made.append((t, word))
        else:
            out.append(t)
    return tuple(out), tuple(made)
