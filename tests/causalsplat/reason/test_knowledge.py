"""The knowledge table (``causalsplat/reason/data/knowledge.toml``) and its loader.

Coverage: every ScanNet200 category is an entry; every category of the synthetic
vocabulary resolves; every raw ScanNet object label used in at least 2 scans (read from the
ReferIt3D object tables under ``../shared/data``, skipped when absent) is an entry key or an
alias. Then the review rules of the table, the loader's lookups and its schema errors.
"""

from __future__ import annotations

import fnmatch
import json
import re
import subprocess
import sys
import tomllib
from collections import Counter
from importlib import resources
from pathlib import Path

import pytest

from causalsplat.reason.errors import ReasonError
from causalsplat.reason.knowledge import (
    FORMAT,
    MAX_CHARS,
    Knowledge,
    ObjectFacts,
    knowledge_json,
    load_knowledge,
    normalize,
)
from causalsplat.synth.vocab import CATEGORIES
from tests.conftest import REPO_ROOT, shared_data_path

# Source: ScanNet/ScanNet, BenchmarkScripts/ScanNet200/scannet200_constants.py,
# CLASS_LABELS_200 (commit 520d564556f919c037ea2ac09961abd6b09f1294), in its order.
# fmt: off
CLASS_LABELS_200 = (
    'wall', 'chair', 'floor', 'table', 'door', 'couch', 'cabinet', 'shelf', 'desk',
    'office chair', 'bed', 'pillow', 'sink', 'picture', 'window', 'toilet', 'bookshelf',
    'monitor', 'curtain', 'book', 'armchair', 'coffee table', 'box', 'refrigerator', 'lamp',
    'kitchen cabinet', 'towel', 'clothes', 'tv', 'nightstand', 'counter', 'dresser', 'stool',
    'cushion', 'plant', 'ceiling', 'bathtub', 'end table', 'dining table', 'keyboard', 'bag',
    'backpack', 'toilet paper', 'printer', 'tv stand', 'whiteboard', 'blanket',
    'shower curtain', 'trash can', 'closet', 'stairs', 'microwave', 'stove', 'shoe',
    'computer tower', 'bottle', 'bin', 'ottoman', 'bench', 'board', 'washing machine',
    'mirror', 'copier', 'basket', 'sofa chair', 'file cabinet', 'fan', 'laptop', 'shower',
    'paper', 'person', 'paper towel dispenser', 'oven', 'blinds', 'rack', 'plate',
    'blackboard', 'piano', 'suitcase', 'rail', 'radiator', 'recycling bin', 'container',
    'wardrobe', 'soap dispenser', 'telephone', 'bucket', 'clock', 'stand', 'light',
    'laundry basket', 'pipe', 'clothes dryer', 'guitar', 'toilet paper holder', 'seat',
    'speaker', 'column', 'bicycle', 'ladder', 'bathroom stall', 'shower wall', 'cup',
    'jacket', 'storage bin', 'coffee maker', 'dishwasher', 'paper towel roll', 'machine',
    'mat', 'windowsill', 'bar', 'toaster', 'bulletin board', 'ironing board', 'fireplace',
    'soap dish', 'kitchen counter', 'doorframe', 'toilet paper dispenser', 'mini fridge',
    'fire extinguisher', 'ball', 'hat', 'shower curtain rod', 'water cooler', 'paper cutter',
    'tray', 'shower door', 'pillar', 'ledge', 'toaster oven', 'mouse',
    'toilet seat cover dispenser', 'furniture', 'cart', 'storage container', 'scale',
    'tissue box', 'light switch', 'crate', 'power outlet', 'decoration', 'sign', 'projector',
    'closet door', 'vacuum cleaner', 'candle', 'plunger', 'stuffed animal', 'headphones',
    'dish rack', 'broom', 'guitar case', 'range hood', 'dustpan', 'hair dryer',
    'water bottle', 'handicap bar', 'purse', 'vent', 'shower floor', 'water pitcher',
    'mailbox', 'bowl', 'paper bag', 'alarm clock', 'music stand', 'projector screen',
    'divider', 'laundry detergent', 'bathroom counter', 'object', 'bathroom vanity',
    'closet wall', 'laundry hamper', 'bathroom stall door', 'ceiling light', 'trash bin',
    'dumbbell', 'stair rail', 'tube', 'bathroom cabinet', 'cd case', 'closet rod',
    'coffee kettle', 'structure', 'shower head', 'keyboard piano', 'case of water bottles',
    'coat rack', 'storage organizer', 'folded chair', 'fire alarm', 'power strip', 'calendar',
    'poster', 'potted plant', 'luggage', 'mattress',
)
# fmt: on

#: Generic labels that name no particular kind of thing: their entries are short and say
#: so ("an unspecified ..."); they are exempt from nothing else.
GENERIC = (
    "object", "structure", "furniture", "machine", "container", "stand", "case", "dispenser",
    "seat",
)  # fmt: skip

#: Generic dataset labels that are aliases of the generic entries, not entries of their own.
GENERIC_ALIASES = {
    "otherprop": "object",
    "stuff": "object",
    "otherfurniture": "furniture",
    "otherstructure": "structure",
}

#: The room names ``found_in`` may use.
ROOMS = frozenset({
    "any room", "bathroom", "bedroom", "break room", "classroom", "closet", "conference room",
    "copy room", "dining room", "dorm room", "entryway", "game room", "garage", "gym",
    "hallway", "kitchen", "laundry room", "library", "living room", "lobby", "lounge",
    "music room", "office", "storage room",
})  # fmt: skip

#: Raw labels count when they occur in at least this many scans.
MIN_SCANS = 2


@pytest.fixture(scope="module")
def kb() -> Knowledge:
    return load_knowledge()


def _all_strings(f: ObjectFacts) -> tuple[str, ...]:
    return (f.is_a, *f.also, *f.uses, *f.affords, *f.holds, *f.found_in)


# -- coverage ----------------------------------------------------------------------------


def test_scannet200_list_is_the_benchmark_list() -> None:
    assert len(CLASS_LABELS_200) == len(set(CLASS_LABELS_200)) == 200


def test_every_scannet200_category_is_an_entry(kb: Knowledge) -> None:
    missing = [c for c in CLASS_LABELS_200 if c not in kb.names]
    assert not missing, f"ScanNet200 categories without an entry: {missing}"


def test_every_synthetic_category_resolves(kb: Knowledge) -> None:
    missing = [c for c in CATEGORIES if kb.get(c) is None]
    assert not missing, f"synthetic categories the table does not know: {missing}"
    assert kb.get("fridge").name == "refrigerator"  # type: ignore[union-attr]
    assert kb.get("sofa").name == "couch"  # type: ignore[union-attr]


@pytest.mark.shared_data
def test_raw_scannet_labels_are_covered(kb: Knowledge) -> None:
    folder = shared_data_path("referit3d_scannet_objects", "objects_info")
    scans: Counter[str] = Counter()
    for path in sorted(folder.glob("*.json")):
        objects = json.loads(path.read_text(encoding="utf-8"))
        scans.update({normalize(o["label"]) for o in objects})
    labels = sorted(label for label, n in scans.items() if n >= MIN_SCANS)
    assert len(labels) > 200  # the folder is the full object tables, not a stub
    missing = [label for label in labels if label not in kb]
    assert not missing, f"raw labels (>= {MIN_SCANS} scans) the table does not know: {missing}"


def test_generic_entries_say_they_are_generic(kb: Knowledge) -> None:
    for name in GENERIC:
        facts = kb.get(name)
        assert facts is not None and facts.name == name
        assert re.match(r"an (unspecified|unidentified) ", facts.is_a), name
    for alias, owner in GENERIC_ALIASES.items():
        assert kb.get(alias).name == owner  # type: ignore[union-attr]


# -- review rules of the shipped table -----------------------------------------------------


def test_every_entry_has_uses_affordances_and_rooms(kb: Knowledge) -> None:
    for f in kb:
        assert f.uses, f.name
        assert 3 <= len(f.uses) <= 8, (f.name, f.uses)
        assert 2 <= len(f.affords) <= 6, (f.name, f.affords)
        assert f.found_in and set(f.found_in) <= ROOMS, (f.name, f.found_in)
        assert len(set(f.uses)) == len(f.uses), f.name


def test_strings_are_short_lower_case_and_unpunctuated(kb: Knowledge) -> None:
    bad = [
        (f.name, s)
        for f in kb
        for s in _all_strings(f)
        if len(s) > MAX_CHARS or s != s.strip().lower() or "  " in s or s[-1] in ".,;:!?"
    ]
    assert not bad, f"strings breaking the review rules: {bad}"


def test_the_data_files_are_found_and_packaged() -> None:
    data = resources.files("causalsplat.reason") / "data"
    assert tomllib.loads((data / "knowledge.toml").read_text(encoding="utf-8"))["format"] == FORMAT
    assert json.loads((data / "knowledge.json").read_text(encoding="utf-8"))["format"] == FORMAT
    pyproject = tomllib.loads((REPO_ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    globs = pyproject["tool"]["setuptools"]["package-data"]["causalsplat"]
    for name in ("knowledge.toml", "knowledge.json"):
        assert any(fnmatch.fnmatch(f"reason/data/{name}", g) for g in globs), name
    assert load_knowledge() is load_knowledge()


def test_the_shipped_json_is_generated_from_the_toml() -> None:
    data = resources.files("causalsplat.reason") / "data"
    expected = knowledge_json((data / "knowledge.toml").read_text(encoding="utf-8"))
    assert (data / "knowledge.json").read_text(encoding="utf-8") == expected, (
        "knowledge.toml changed: run scripts/make_knowledge_json.py"
    )


def test_the_generator_script_writes_the_json(tmp_path: Path) -> None:
    out = tmp_path / "knowledge.json"
    script = REPO_ROOT / "scripts" / "make_knowledge_json.py"
    subprocess.run([sys.executable, str(script), "-o", str(out)], check=True, capture_output=True)
    data = resources.files("causalsplat.reason") / "data"
    assert out.read_text(encoding="utf-8") == (data / "knowledge.json").read_text(encoding="utf-8")


def test_json_and_toml_forms_load_the_same_table(tmp_path: Path) -> None:
    text = f'format = "{FORMAT}"\n{_GOOD}[stool]\nalso = ["stools"]\nis = "a seat"\nfor = ["x"]\n'
    (tmp_path / "k.json").write_text(knowledge_json(text), encoding="utf-8")
    from_json = load_knowledge(tmp_path / "k.json")
    assert list(from_json) == list(_load(tmp_path, text))
    assert from_json.get("stools").name == "stool"  # type: ignore[union-attr]
    (tmp_path / "bad.json").write_text("[1]", encoding="utf-8")
    with pytest.raises(ReasonError, match="must be a JSON object"):
        load_knowledge(tmp_path / "bad.json")


# -- lookups and descriptions --------------------------------------------------------------


def test_lookup_by_key_and_alias(kb: Knowledge) -> None:
    assert kb.get("refrigerator").name == "refrigerator"  # type: ignore[union-attr]
    assert kb.get("refridgerator").name == "refrigerator"  # type: ignore[union-attr]
    assert kb.get("  Mini   Fridge ").name == "mini fridge"  # type: ignore[union-attr]
    assert kb.get("Kitchen Cabinets").name == "kitchen cabinet"  # type: ignore[union-attr]
    assert "fridge" in kb and "FRIDGE" in kb and "unobtainium" not in kb and 3 not in kb
    assert kb.get("unobtainium") is None
    assert len(kb) == len(kb.names) == len(list(kb))
    assert list(kb.names) == sorted(kb.names)


def test_descriptions_name_the_object_once_per_fact(kb: Knowledge) -> None:
    f = kb.get("towel")
    assert f is not None
    d = f.descriptions()
    assert all(s.startswith("towel: ") for s in d)
    assert d[0] == f"towel: {f.is_a}"
    assert "towel: used for drying your hands and body after washing" in d
    assert "towel: you can dry off with" in d
    assert "towel: found in the bathroom or the kitchen" in d
    extra = bool(f.holds) + bool(f.found_in) + bool(f.also)
    assert len(d) == 1 + len(f.uses) + len(f.affords) + extra
    assert "wall: found in any room" in kb.get("wall").descriptions()  # type: ignore[union-attr]


# -- schema errors -------------------------------------------------------------------------

_GOOD = '[chair]\nis = "a seat"\nfor = ["sitting down"]\n'


def _load(tmp_path: Path, text: str) -> Knowledge:
    path = tmp_path / "knowledge.toml"
    path.write_text(text, encoding="utf-8")
    return load_knowledge(path)


def test_a_minimal_table_loads(tmp_path: Path) -> None:
    kb = _load(tmp_path, f'format = "{FORMAT}"\n{_GOOD}')
    chair = kb.get("chair")
    assert chair is not None
    assert chair == ObjectFacts("chair", (), "a seat", ("sitting down",), (), (), ())
    assert chair.descriptions() == ("chair: a seat", "chair: used for sitting down")


_F = f'format = "{FORMAT}"\n'
_STOOL = '[stool]\nis = "a seat"\nfor = ["sitting"]\n'

#: Broken tables, by test id: (TOML text, the pattern the error message must match).
_BAD = {
    "no-format": (_GOOD, r"format None, expected 'causalsplat-knowledge/1'"),
    "wrong-format": (
        f'format = "causalsplat-knowledge/0"\n{_GOOD}',
        r"format 'causalsplat-knowledge/0', expected",
    ),
    "bad-toml": (f"{_F}[chair\n", r"not valid TOML"),
    "stray-key": (f"{_F}version = 2\n", r"top-level key 'version' must be an entry table"),
    "unknown-field": (f'{_F}{_GOOD}color = "red"\n', r"entry 'chair': unknown field 'color'"),
    "missing-is": (f'{_F}[chair]\nfor = ["x"]\n', r"entry 'chair': field 'is' must be a non-"),
    "is-not-string": (
        f'{_F}[chair]\nis = 3\nfor = ["x"]\n',
        r"entry 'chair': field 'is' must be a non-empty string",
    ),
    "for-not-list": (
        f'{_F}[chair]\nis = "a seat"\nfor = "sitting"\n',
        r"entry 'chair': field 'for' must be a list of strings",
    ),
    "holds-not-strings": (
        f"{_F}{_GOOD}holds = [1, 2]\n",
        r"entry 'chair': field 'holds' must be a list of strings",
    ),
    "empty-string": (
        f'{_F}{_GOOD}affords = ["sit", " "]\n',
        r"entry 'chair': field 'affords' holds an empty string",
    ),
    "empty-for": (
        f'{_F}[chair]\nis = "a seat"\nfor = []\n',
        r"entry 'chair': field 'for' must not be empty",
    ),
    "missing-for": (
        f'{_F}[chair]\nis = "a seat"\n',
        r"entry 'chair': field 'for' must not be empty",
    ),
    "alias-twice": (
        f'{_F}{_GOOD}also = ["seat"]\n{_STOOL}also = ["Seat"]\n',
        r"entry 'stool': field 'also': alias 'Seat' is already claimed by 'chair'",
    ),
    "alias-is-entry": (
        f'{_F}{_GOOD}also = ["stool"]\n{_STOOL}',
        r"entry 'chair': field 'also': alias 'stool' is itself an entry",
    ),
    "upper-case-key": (
        f'{_F}[Chair]\nis = "a seat"\nfor = ["sitting"]\n',
        r"entry 'Chair': key must be lower case",
    ),
}


@pytest.mark.parametrize(("text", "message"), list(_BAD.values()), ids=list(_BAD))
def test_schema_errors_name_the_entry_and_field(tmp_path: Path, text: str, message: str) -> None:
    with pytest.raises(ReasonError, match=message) as info:
        _load(tmp_path, text)
    assert "\n" not in str(info.value)
    assert str(info.value).startswith(str(tmp_path / "knowledge.toml"))
