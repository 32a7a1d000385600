"""Generate the offline reasoner's lexicon from the WordNet 3.0 database files.

Reads the plain database files of WordNet (Debian package ``wordnet-base``: ``apt-get install
-y wordnet-base`` puts them under ``/usr/share/wordnet``) and writes
``causalsplat/reason/data/lexicon.json.gz``: a compact JSON document holding

* ``nouns``: the noun synsets of physical things (hyponyms of ``artifact``, ``natural
  object``, ``plant``, ``food`` and ``colour``, and of every affordance seed), each as one
  tab-separated string ``lemmas<TAB>hypernyms<TAB>verbs<TAB>gloss``: its lemmas
  (``|``-separated, spaces for underscores), the indices of its hypernyms inside the list
  and of its derivationally related verb synsets (``,``-separated, possibly empty), and its
  definition (the gloss without its quoted usage examples);
* ``verbs``: every verb synset, as ``lemmas<TAB>hypernyms<TAB>nouns``;
* ``noun_index`` / ``verb_index``: lemma -> synset indices (``,``-separated) in WordNet's
  sense order (the first is the most frequent sense);
* ``affordances``: for each affordance phrase, the noun synsets whose hyponyms afford it
  (the seed table below, resolved to synset indices);
* ``colors``: single-word colour names (hyponyms of ``colour``);
* ``exceptions``: the irregular inflections of ``noun.exc``, ``verb.exc`` and ``adj.exc``
  (inflected form -> lemma), one table per part of speech (``n``, ``v``, ``a``);
* ``words``: every single-word lemma of WordNet (nouns, verbs, adjectives and adverbs),
  sorted and space-separated: the English words the reasoner tells from misspellings;
* ``licence``: the WordNet 3.0 licence, which must accompany every copy of the data.

Usage::

    python scripts/make_lexicon.py [--wordnet /usr/share/wordnet] [-o PATH]
    python scripts/make_lexicon.py --show chair   # print the senses of a word and exit

The output is deterministic: the same WordNet files give the same bytes. Rows and index
entries are strings, not nested lists, so that reading the file creates few objects for
Python's garbage collector to track (a cold ``causalsplat ask`` reads it whole); the
reader splits a row when it is first used.
"""

from __future__ import annotations

import argparse
import gzip
import json
import sys
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

WORDNET = Path("/usr/share/wordnet")
OUT = Path(__file__).resolve().parent.parent / "causalsplat" / "reason" / "data" / "lexicon.json.gz"
FORMAT = "causalsplat-lexicon/5"

#: Roots of the noun subtrees that are shipped: (lemma, sense number in WordNet 3.0).
NOUN_ROOTS: tuple[tuple[str, int], ...] = (
    ("artifact", 1),
    ("natural object", 1),
    ("plant", 2),
    ("food", 1),
    ("food", 2),
    ("color", 1),
)

#: What things afford, by the WordNet senses whose hyponyms afford it. A sense is
#: ``lemma.n.N`` (N counted in WordNet's sense order). Chosen by hand from the glosses.
AFFORDANCE_SEEDS: dict[str, tuple[str, ...]] = {
    "sit": ("seat.n.03", "chair.n.01", "sofa.n.01", "bench.n.01", "stool.n.01", "ottoman.n.03"),
    "lie down": ("bed.n.01", "sofa.n.01", "mattress.n.01"),
    "sleep": ("bed.n.01", "bunk.n.03", "mattress.n.01"),
    "place items": (
        "table.n.02",
        "desk.n.01",
        "counter.n.01",
        "shelf.n.01",
        "tray.n.01",
        "stand.n.04",
        "dresser.n.01",
        "cabinet.n.01",
    ),
    "store items": (
        "cabinet.n.01",
        "shelf.n.01",
        "bookcase.n.01",
        "box.n.01",
        "drawer.n.01",
        "dresser.n.01",
        "wardrobe.n.01",
        "chest.n.02",
        "basket.n.01",
        "bag.n.01",
        "bin.n.01",
        "closet.n.01",
    ),
    "dine": ("table.n.02",),
    "work": ("desk.n.01", "computer.n.01", "laptop.n.01", "workbench.n.01"),
    "wash hands": ("sink.n.01", "washbasin.n.01", "soap.n.01"),
    "wash dishes": ("sink.n.01", "dishwasher.n.01"),
    "heat food": ("stove.n.01", "microwave.n.02", "oven.n.01", "toaster.n.02"),
    "cook": ("stove.n.01", "oven.n.01", "kitchen_range.n.01"),
    "cook in": ("pot.n.01", "pan.n.01", "cooking_utensil.n.01"),
    "store food": ("refrigerator.n.01", "cupboard.n.01"),
    "cool food": ("refrigerator.n.01",),
    "drink": ("cup.n.01", "drinking_vessel.n.01", "bottle.n.01", "glass.n.02", "mug.n.04"),
    "eat": ("plate.n.04", "bowl.n.03", "dish.n.01"),
    "read": ("book.n.02", "publication.n.01", "magazine.n.02", "newspaper.n.03"),
    "write": ("blackboard.n.01", "board.n.05", "desk.n.01", "pen.n.01", "pencil.n.01"),
    "illuminate": ("lamp.n.01", "lamp.n.02", "light.n.02", "chandelier.n.01", "lantern.n.01"),
    "dry hands": ("towel.n.01",),
    "rest head": ("pillow.n.01", "cushion.n.03"),
    "carry items": ("tray.n.01", "bag.n.01", "basket.n.01", "backpack.n.01", "suitcase.n.01"),
    "decorate": ("plant.n.02", "picture.n.01", "vase.n.01", "decoration.n.01", "flower.n.01"),
    "watch": ("television_receiver.n.01", "monitor.n.04", "screen.n.03"),
    "throw away trash": ("ashcan.n.01", "wastepaper_basket.n.01", "bin.n.01"),
    "hang clothes": ("rack.n.05", "hanger.n.02", "hook.n.04", "wardrobe.n.01"),
    "open": ("door.n.01", "window.n.01", "drawer.n.01"),
    "bathe": ("bathtub.n.01", "shower.n.01", "shower_stall.n.01"),
    "look at reflection": ("mirror.n.01",),
    "type": ("computer_keyboard.n.01", "typewriter.n.01"),
    "print": ("printer.n.03",),
    "tell time": ("clock.n.01", "watch.n.01"),
    "play music": ("musical_instrument.n.01", "piano.n.01", "guitar.n.01"),
    "keep warm": ("blanket.n.01", "radiator.n.02", "heater.n.01", "quilt.n.01"),
    "use the toilet": ("toilet.n.02",),
}


@dataclass
class Synset:
    offset: str
    lemmas: list[str]
    hypernyms: list[str] = field(default_factory=list)
    derived: list[tuple[str, str]] = field(default_factory=list)  # (pos, offset)
    gloss: str = ""


def read_licence(root: Path) -> str:
    """The licence header of the data files (lines starting with two spaces)."""
    lines = []
    with (root / "data.noun").open(encoding="latin-1") as handle:
        for line in handle:
            if not line.startswith("  "):
                break
            text = line[2:].rstrip()
            number, _, rest = text.partition(" ")
            lines.append(rest if number.isdigit() else text)
    return "\n".join(lines).strip() + "\n"


def read_data(root: Path, pos: str) -> dict[str, Synset]:
    """Parse ``data.<pos>`` into synsets keyed by offset."""
    out: dict[str, Synset] = {}
    with (root / f"data.{pos}").open(encoding="latin-1") as handle:
        for line in handle:
            if line.startswith("  "):
                continue
            fields, _, gloss = line.partition(" | ")
            parts = fields.split()
            offset, w_cnt = parts[0], int(parts[3], 16)
            words = [parts[4 + 2 * i] for i in range(w_cnt)]
            lemmas = []
            for w in words:
                w = w.split("(")[0].replace("_", " ").lower()
                if w not in lemmas:
                    lemmas.append(w)
            i = 4 + 2 * w_cnt
            p_cnt = int(parts[i])
            synset = Synset(offset, lemmas, gloss=definition(gloss))
            for j in range(p_cnt):
                symbol, target, target_pos = parts[i + 1 + 4 * j : i + 4 + 4 * j]
                if symbol in ("@", "@i"):
                    synset.hypernyms.append(target)
                elif symbol == "+":
                    synset.derived.append((target_pos, target))
            out[offset] = synset
    return out


def definition(gloss: str) -> str:
    """The definition part of a WordNet gloss: its quoted usage examples dropped."""
    parts = [p.strip() for p in gloss.split(";")]
    kept = [p for p in parts if p and not p.startswith('"')]
    return "; ".join(kept).strip()


def read_index(root: Path, pos: str) -> dict[str, list[str]]:
    """``index.<pos>``: lemma -> synset offsets in sense order."""
    out: dict[str, list[str]] = {}
    with (root / f"index.{pos}").open(encoding="latin-1") as handle:
        for line in handle:
            if line.startswith("  "):
                continue
            parts = line.split()
            lemma, synset_cnt, p_cnt = parts[0], int(parts[2]), int(parts[3])
            offsets = parts[4 + p_cnt + 2 :]
            if len(offsets) != synset_cnt:
                raise ValueError(f"index.{pos}: bad line for {lemma!r}")
            out[lemma.replace("_", " ")] = offsets
    return out


def read_exceptions(root: Path) -> dict[str, dict[str, str]]:
    """Irregular forms -> lemma (the first lemma listed), one table per part of speech
    (``"n"``, ``"v"``, ``"a"``): "stood" is a form of the verb *stand*, never of the noun."""
    out: dict[str, dict[str, str]] = {}
    for pos, key in (("noun", "n"), ("verb", "v"), ("adj", "a")):
        table: dict[str, str] = {}
        with (root / f"{pos}.exc").open(encoding="latin-1") as handle:
            for line in handle:
                parts = line.split()
                if len(parts) >= 2:
                    form = parts[0].replace("_", " ")
                    table.setdefault(form, parts[1].replace("_", " "))
        out[key] = dict(sorted(table.items()))
    return out


def single_words(root: Path) -> str:
    """Every single-word lemma of the four ``index.<pos>`` files, sorted, space-separated."""
    words: set[str] = set()
    for pos in ("noun", "verb", "adj", "adv"):
        words.update(w for w in read_index(root, pos) if w.isalpha() and w.isascii())
    return " ".join(sorted(words))


def sense(index: dict[str, list[str]], name: str) -> str:
    """The offset of ``lemma.n.N``."""
    lemma, _pos, number = name.rsplit(".", 2)
    offsets = index.get(lemma.replace("_", " "))
    if not offsets or int(number) > len(offsets):
        raise KeyError(f"WordNet has no sense {name!r}")
    return offsets[int(number) - 1]


def hyponym_closure(nouns: dict[str, Synset], roots: list[str]) -> set[str]:
    children: dict[str, list[str]] = defaultdict(list)
    for s in nouns.values():
        for h in s.hypernyms:
            children[h].append(s.offset)
    seen = set(roots)
    stack = list(roots)
    while stack:
        for child in children[stack.pop()]:
            if child not in seen:
                seen.add(child)
                stack.append(child)
    return seen


def ints(values: list[int]) -> str:
    """Synset indices as the file writes them: ``,``-separated, empty for none."""
    return ",".join(map(str, values))


def build(root: Path) -> dict[str, object]:
    nouns, verbs = read_data(root, "noun"), read_data(root, "verb")
    noun_index, verb_index = read_index(root, "noun"), read_index(root, "verb")
    roots = [sense(noun_index, f"{lemma.replace(' ', '_')}.n.{n}") for lemma, n in NOUN_ROOTS]
    roots += [sense(noun_index, name) for names in AFFORDANCE_SEEDS.values() for name in names]
    kept = sorted(hyponym_closure(nouns, roots))
    noun_pos = {off: i for i, off in enumerate(kept)}
    verb_order = sorted(verbs)
    verb_pos = {off: i for i, off in enumerate(verb_order)}

    def noun_row(s: Synset) -> str:
        hyper = sorted(noun_pos[h] for h in s.hypernyms if h in noun_pos)
        derived = sorted({verb_pos[o] for p, o in s.derived if p == "v" and o in verb_pos})
        return "\t".join(("|".join(s.lemmas), ints(hyper), ints(derived), s.gloss))

    def verb_row(s: Synset) -> str:
        hyper = sorted(verb_pos[h] for h in s.hypernyms if h in verb_pos)
        derived = sorted({noun_pos[o] for p, o in s.derived if p == "n" and o in noun_pos})
        return "\t".join(("|".join(s.lemmas), ints(hyper), ints(derived)))

    def restricted(index: dict[str, list[str]], pos: dict[str, int]) -> dict[str, str]:
        out = {}
        for lemma in sorted(index):
            ids = [pos[o] for o in index[lemma] if o in pos]
            if ids:
                out[lemma] = ints(ids)
        return out

    color_root = noun_pos[sense(noun_index, "color.n.01")]
    colors = sorted(
        {
            lemma
            for off in hyponym_closure(nouns, [kept[color_root]])
            for lemma in nouns[off].lemmas
            if " " not in lemma and "-" not in lemma and lemma.isalpha()
        }
    )
    affordances = {
        phrase: sorted({noun_pos[sense(noun_index, name)] for name in names})
        for phrase, names in sorted(AFFORDANCE_SEEDS.items())
    }
    return {
        "format": FORMAT,
        "source": "WordNet 3.0 (Princeton University), database files of Debian wordnet-base",
        "licence": read_licence(root),
        "nouns": [noun_row(nouns[off]) for off in kept],
        "verbs": [verb_row(verbs[off]) for off in verb_order],
        "noun_index": restricted(noun_index, noun_pos),
        "verb_index": restricted(verb_index, verb_pos),
        "affordances": affordances,
        "colors": colors,
        "exceptions": read_exceptions(root),
        "words": single_words(root),
    }


def show(root: Path, word: str) -> None:
    for pos in ("noun", "verb"):
        index = read_index(root, pos)
        data = read_data(root, pos)
        for n, off in enumerate(index.get(word, []), start=1):
            gloss = ""
            with (root / f"data.{pos}").open(encoding="latin-1") as handle:
                for line in handle:
                    if line.startswith(off + " "):
                        gloss = line.partition(" | ")[2].strip()
                        break
            print(f"{word}.{pos[0]}.{n:02d}  {', '.join(data[off].lemmas)}  -- {gloss[:90]}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--wordnet", type=Path, default=WORDNET, help="WordNet dict folder")
    parser.add_argument("-o", "--output", type=Path, default=OUT, help="output .json.gz")
    parser.add_argument("--show", metavar="WORD", help="print the senses of WORD and exit")
    args = parser.parse_args(argv)
    if not (args.wordnet / "data.noun").exists():
        print(
            f"make_lexicon: no WordNet database under {args.wordnet}"
            " (apt-get install -y wordnet-base)",
            file=sys.stderr,
        )
        return 1
    if args.show:
        show(args.wordnet, args.show.replace("_", " "))
        return 0
    document = build(args.wordnet)
    text = json.dumps(document, ensure_ascii=False, separators=(",", ":"), sort_keys=True)
    args.output.parent.mkdir(parents=True, exist_ok=True)
    with gzip.GzipFile(args.output, "wb", compresslevel=9, mtime=0) as handle:
        handle.write(text.encode("utf-8"))
    nouns, verbs = len(document["nouns"]), len(document["verbs"])  # type: ignore[arg-type]
    size = args.output.stat().st_size
    print(f"wrote {args.output}: {nouns} noun and {verbs} verb synsets, {size} bytes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
