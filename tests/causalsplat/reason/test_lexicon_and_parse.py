"""The shipped lexicon, its generator, the tokenizer and stage 1 (parsing)."""

from __future__ import annotations

import gzip
import json
import subprocess
import sys
from pathlib import Path

import pytest

from causalsplat.reason import SceneContext
from causalsplat.reason._text import tokenize
from causalsplat.reason.lexicon import load_lexicon
from causalsplat.reason.offline import OfflineReasoner
from tests.conftest import REPO_ROOT

LEX = load_lexicon()
DATA = REPO_ROOT / "causalsplat" / "reason" / "data" / "lexicon.json.gz"


def test_lexicon_morphology_synonyms_affordances() -> None:
    assert [LEX.lemma(w) for w in ("shelves", "boxes", "chairs", "knives")] == [
        "shelf", "box", "chair", "knife"
    ]  # fmt: skip
    assert LEX.phrase_lemma(["kitchen", "cabinets"]) == "kitchen cabinet"
    assert {"couch", "lounge"} <= set(LEX.synonyms("sofa"))
    assert "garbage can" in LEX.synonyms("trash can")
    assert LEX.affordances("armchair") == ("sit",)
    assert LEX.affordances("office chair") == ("sit",)  # through its head noun
    assert "heat food" in LEX.affordances("microwave")
    assert "dine" in LEX.related_words("dinner")
    assert "place" in LEX.related_words("put")


def test_irregular_forms_are_read_in_their_own_part_of_speech() -> None:
    # "stood", "lit", "hung" are forms of verbs; as nouns they name nothing (never a
    # "stand", a "light" or a "hang")
    assert [LEX.lemma(w) for w in ("stood", "lit", "hung")] == ["stood", "lit", "hung"]
    assert [LEX.lemma(w, "v") for w in ("stood", "lit", "hung")] == ["stand", "light", "hang"]
    assert [LEX.lemma(w) for w in ("feet", "mice")] == ["foot", "mouse"]
    assert LEX.is_word("stood") and LEX.is_word("feet") and not LEX.is_word("chiar")


def test_shipped_file_keeps_the_wordnet_licence() -> None:
    document = json.loads(gzip.decompress(DATA.read_bytes()))
    assert "Princeton University" in document["licence"]
    assert "WordNet 3.0 Copyright 2006 by Princeton University" in document["licence"]
    assert document["format"] == "causalsplat-lexicon/5"


@pytest.mark.skipif(not Path("/usr/share/wordnet/data.noun").exists(), reason="no wordnet-base")
def test_generator_reproduces_the_shipped_file(tmp_path: Path) -> None:
    out = tmp_path / "lexicon.json.gz"
    script = REPO_ROOT / "scripts" / "make_lexicon.py"
    subprocess.run([sys.executable, str(script), "-o", str(out)], check=True, capture_output=True)
    assert out.read_bytes() == DATA.read_bytes()


def test_tokenizer() -> None:
    assert tokenize("Facing the T.V., pick the chair that's left-of it!") == (
        "facing", "the", "tv", ",", "pick", "the", "chair", "that", "is", "left", "of",
        "it", ".",
    )  # fmt: skip
    assert tokenize("It isn't the mug") == ("it", "is", "not", "the", "mug")


def test_stage_one_reads_sr3d_templates(room: SceneContext) -> None:
    parse = OfflineReasoner().parse
    ins = parse("choose the chair that is in the middle of the couch and the lamp", room)
    assert ins.kind == "refer" and ins.target is not None
    assert ins.target.categories == ("chair",)
    (c,) = ins.target.constraints
    assert c.kind == "between" and [a.categories for a in c.anchors] == [("couch",), ("lamp",)]
    ins = parse("facing the front of the table, pick the cup that is to the left of it", room)
    assert ins.viewpoint is not None and ins.viewpoint.categories == ("table",)
    assert ins.target is not None and ins.target.constraints[0].kind == "left_of"
    ins = parse("the box with a cup on top of it", room)
    assert ins.target is not None and ins.target.constraints[0].kind == "supports"
    ins = parse("the cup that is not on the box", room)
    assert ins.target is not None and ins.target.constraints[0].negated
    ins = parse("if the box and the table are removed, what falls?", room)
    assert ins.kind == "counterfactual" and [np.categories for np in ins.removed] == [
        ("box",), ("table",)
    ]  # fmt: skip
    assert parse("what can I sit on?", room).kind == "action"
    assert parse("the blue cup", room).is_intrinsic


def test_a_kind_noun_before_to_and_a_verb_opens_a_purpose(room: SceneContext) -> None:
    parse = OfflineReasoner().parse
    # "a device to ..." names no category itself: the purpose decides what is wanted
    ins = parse("I need a device to heat my soup", room)
    assert ins.kind == "action" and ins.purpose_start == 5
    assert ins.target is None or ins.target.mention is None
    # a noun that names a category is itself what is wanted
    assert parse("I need a cup to drink from", room).target.categories == ("cup",)  # type: ignore[union-attr]
    # "to" before no verb, or in a sentence that wants nothing, opens no purpose
    assert parse("the table has a cup next to it", room).kind == "refer"
    assert parse("the box with a lid to the left of the cup", room).kind == "refer"


def test_misspelt_words_are_read_as_the_scene_word_they_were_meant_to_be(
    room: SceneContext,
) -> None:
    reasoner = OfflineReasoner()

    def answer(text: str) -> tuple[tuple[int, ...], str]:
        a = reasoner.answer(text, room)
        return a.entity_ids, a.explanation.splitlines()[0]

    right, _ = answer("the chair closest to the couch")
    assert right == (5,)
    ids, reading = answer("the chiar closest to the cuoch")
    assert ids == right
    assert "'chiar' read as 'chair'" in reading and "'cuoch' read as 'couch'" in reading
    # a colour word misspelt still names the colour, and the blue cup is not the red one
    assert answer("the bule cup")[0] == answer("the blue cup")[0] == (4,)
    # real words are never changed: "hair" is a word, one edit from "chair" or not
    ids, reading = answer("the hair closest to the couch")
    assert reading == "read as: refer 'hair'; closest 'couch'" and ids != right
    assert LEX.is_word("tabel") is False and LEX.is_word("tables") is True


def test_a_run_together_category_name_is_read_as_its_words() -> None:
    from causalsplat.reason._spelling import correct

    vocabulary = frozenset({"trash", "can", "table"})
    tokens = ("the", "trashcans", "by", "the", "tabel")
    assert correct(tokens, vocabulary, LEX.is_word, ("trash can", "table")) == (
        ("the", "trash", "cans", "by", "the", "table"),
        (("trashcans", "trash cans"), ("tabel", "table")),
    )


def test_a_count_before_a_noun_of_removal_is_no_removal(room: SceneContext) -> None:
    reasoner = OfflineReasoner()
    looked = reasoner.answer(
        "if you are looking at the 2 chairs, the correct one is on the right", room
    )
    assert not looked.explanation.startswith("read as: counterfactual")
    removed = reasoner.answer("if the 2 trash cans are removed, what falls?", room)
    assert removed.explanation.splitlines()[0] == "read as: counterfactual: remove trash can"


def test_an_ordinal_counted_from_a_thing_ranks_by_distance_to_it(room: SceneContext) -> None:
    reasoner = OfflineReasoner()

    def answer(text: str) -> tuple[tuple[int, ...], str]:
        a = reasoner.answer(text, room)
        return a.entity_ids, a.explanation.splitlines()[0]

    # chairs 5, 6, 7 are 2.6, 4.2 and 5.0 m from the door
    assert answer("the second chair from the door") == (
        (6,),
        "read as: refer 'chair'; closest 'door'",
    )
    assert answer("the chair third from the door")[0] == (7,)
    assert answer("the first chair from the door")[0] == (5,)
    # from a side or an end it is a count along that side, as before
    assert answer("the second chair from the left")[1] == "read as: refer 'chair'; side left #2"


def test_coming_in_without_a_place_is_coming_in_through_the_door(room: SceneContext) -> None:
    reasoner = OfflineReasoner()
    at_door = reasoner.answer("standing at the door, the chair on your left", room)
    for text in ("as you walk in, the chair on your left",
                 "when you enter the room, the chair on your left"):  # fmt: skip
        answer = reasoner.answer(text, room)
        assert answer.entity_ids == at_door.entity_ids
        assert answer.explanation.splitlines()[0].endswith("standing at 'door'"), text


def test_the_one_not_near_a_thing_is_the_farthest_of_the_rest(room: SceneContext) -> None:
    # no chair is near the lamp (the stored relation): of the three, the one farthest
    # from it, not the largest
    answer = OfflineReasoner().answer("the chair that is not near the lamp", room)
    assert answer.entity_ids == (5,), answer.explanation
