"""Needs as people say them, and descriptions the scene contradicts.

A need is never answered with every object, and not with whatever merely comes closest:
when nothing in the scene meets it, the answer is empty (``nothing_fits``) with the
closest candidates and what would fit. A description whose colour the scene contradicts
answers nothing, on the target or on an anchor.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from causalsplat.objects import objects_to_scene_graph, parse_objects, read_objects
from causalsplat.reason import SceneContext
from causalsplat.reason.offline import OfflineReasoner

LEXICAL = OfflineReasoner(embeddings=False)


@pytest.fixture(scope="module")
def demo_room(tmp_path_factory: pytest.TempPathFactory) -> SceneContext:
    """The demo's room (synthetic small, seed 0), its ground-truth objects ingested."""
    from causalsplat.synth import synth_scene

    out = tmp_path_factory.mktemp("demo") / "small0"
    synth_scene("small", 0, out)
    return SceneContext(objects_to_scene_graph(read_objects(out / "objects.json")))


@pytest.fixture(scope="module")
def reasoner() -> OfflineReasoner:
    return OfflineReasoner(embeddings=True)


def _non_structural(ctx: SceneContext) -> int:
    return sum(1 for e in ctx.graph.entities if not ctx.is_structural(e))


@pytest.mark.parametrize(
    "text",
    ["which thing needs watering?", "where can the baby play?", "what needs cleaning?",
     "what could I use?", "I want to lie down", "anything to do here?"],
)  # fmt: skip
def test_a_need_is_never_answered_with_everything(
    demo_room: SceneContext, reasoner: OfflineReasoner, text: str
) -> None:
    answer = reasoner.answer(text, demo_room)
    assert len(answer.entity_ids) < _non_structural(demo_room) // 2, answer.explanation


@pytest.mark.parametrize(
    ("text", "category"),
    [
        ("which thing needs watering?", "plant"),
        ("What can I use to heat up my lunch?", "stove"),
        ("Is there anything I can read?", "book"),
        ("I just washed my hands, where can I dry them?", "towel"),
    ],
)
def test_how_can_i_what_can_i_use_and_is_there_anything(
    demo_room: SceneContext, reasoner: OfflineReasoner, text: str, category: str
) -> None:
    answer = reasoner.answer(text, demo_room)
    assert answer.entity_ids and set(answer.categories) == {category}, answer.explanation


@pytest.mark.parametrize(
    "text",
    ["it's too dark in here", "I want to watch a movie", "where can I take a shower?",
     "I need to brush my teeth", "I need warm air to dry my hair", "I want to lie down",
     "How can I wash my hands?", "How can I cool the room?", "I want to soak in hot water"],
)  # fmt: skip
def test_nothing_fits_when_the_room_lacks_what_is_needed(
    demo_room: SceneContext, reasoner: OfflineReasoner, text: str
) -> None:
    # the demo room has no lamp, screen, shower, toothbrush, hair dryer, bed, couch, sink,
    # fan or bathtub; what it stores that its towel and fridge afford ("dry hands", "cool
    # food") does another thing, or to another thing
    answer = reasoner.answer(text, demo_room)
    assert answer.entity_ids == () and answer.nothing_fits
    assert answer.candidates  # the closest candidates come with it
    assert "what would fit" in answer.explanation


def test_the_scene_s_own_affordances_are_held_to_what_the_need_asks(
    demo_room: SceneContext, reasoner: OfflineReasoner
) -> None:
    # the fridge stores "store food": dishes are stored where the scene stores items
    dishes = reasoner.answer("where can I store my dishes?", demo_room)
    assert set(dishes.categories) <= {"cabinet", "nightstand"} and dishes.entity_ids
    # the plant stores "decorate", but people water plants: what needs watering is it
    assert set(reasoner.answer("which thing needs watering?", demo_room).categories) == {"plant"}
    cook = reasoner.answer("I want to cook pasta", demo_room)
    assert cook.entity_ids and set(cook.categories) <= {"stove", "pot"}, cook.explanation


def test_the_activity_a_state_is_too_much_for_is_no_need(room: SceneContext) -> None:
    reasoner = OfflineReasoner()
    for text in ("It's too dark in here.", "It's too dark to read in here.",
                 "it is too dark for reading, what can I do?"):  # fmt: skip
        assert reasoner.answer(text, room).categories == ("lamp",), text


def test_a_state_of_a_thing_is_no_need(room: SceneContext) -> None:
    # "dark" of a thing describes it; of the room it calls for light
    assert LEXICAL.parse("this is dark and in front of the couch", room).kind == "refer"
    assert LEXICAL.parse("a dark brown chair", room).kind == "refer"
    assert LEXICAL.parse("it's too dark in here", room).kind == "action"


def test_what_the_speaker_has_calls_for_something() -> None:
    # "I have a runny nose" is a need (what helps with it), not "anything with a nose";
    # "I have to" stays the need it opens, and a description keeps its reading
    doc = {"scene_id": "have", "objects": [
        {"id": 1, "label": "tissue box", "center": [0, 0, 0.8], "size": [0.2, 0.1, 0.1]},
        {"id": 2, "label": "couch", "center": [2, 0, 0.4], "size": [2, 0.9, 0.8]},
        {"id": 3, "label": "sink", "center": [4, 0, 0.9], "size": [0.5, 0.4, 0.2]},
    ]}  # fmt: skip
    ctx = SceneContext(objects_to_scene_graph(parse_objects(doc)))
    for text in ("I have a runny nose", "I've got a runny nose", "we have a runny nose"):
        assert LEXICAL.parse(text, ctx).kind == "action", text
        assert LEXICAL.answer(text, ctx).categories == ("tissue box",), text
    assert LEXICAL.answer("I have dirty dishes", ctx).categories == ("sink",)
    assert LEXICAL.parse("I have to wash the dishes", ctx).kind == "action"
    assert LEXICAL.parse("the couch that I have", ctx).kind == "refer"


@pytest.mark.parametrize(
    ("text", "contradicted"),
    [
        ("the green cup", "green"),
        ("the grey cup", "grey"),
        ("the cup on the green box", "green"),
        ("the chair near the purple table", "purple"),
    ],
)
def test_a_contradicted_description_answers_none(
    room: SceneContext, text: str, contradicted: str
) -> None:
    answer = LEXICAL.answer(text, room)
    assert answer.entity_ids == () and answer.nothing_fits
    assert f"contradicts {contradicted!r}" in answer.explanation
    assert answer.to_dict()["nothing_fits"] is True


@pytest.mark.parametrize(("text", "expected"), [("the red cup", (2,)),
                                                ("the cup on the white box", (4,))])  # fmt: skip
def test_the_satisfiable_originals_still_answer(
    room: SceneContext, text: str, expected: tuple[int, ...]
) -> None:
    answer = LEXICAL.answer(text, room)
    assert answer.entity_ids == expected and not answer.nothing_fits


def _coloured(*objects: tuple[str, float, tuple[int, int, int]]) -> dict[str, Any]:
    """An objects document of 0.8 m cubes on the floor: (label, x, rgb) each, ids from 1."""
    return {"scene_id": "rgb", "objects": [
        {"id": k, "label": label, "center": [x, 0, 0.4], "size": [0.8, 0.8, 0.8],
         "rgb": list(rgb)}
        for k, (label, x, rgb) in enumerate(objects, start=1)
    ]}  # fmt: skip


def test_colour_by_perceptual_distance_from_rgb(tmp_path: Path) -> None:
    # two armchairs measured as rgb only (no colour names given): "the brown armchair"
    # and "the white one" pick by CIELAB distance; a navy one is "blue", never "red"
    doc = _coloured(("armchair", 0, (120, 80, 50)), ("armchair", 3, (225, 222, 215)))
    doc["objects"] += [
        {"id": 3, "label": "pillow", "center": [3, 0, 0.9], "size": [0.4, 0.3, 0.2],
         "rgb": [20, 40, 130]},
        {"id": 4, "label": "floor", "center": [1.5, 0, -0.01], "size": [6, 4, 0.02]},
    ]  # fmt: skip
    ctx = SceneContext(objects_to_scene_graph(parse_objects(doc)))
    assert LEXICAL.answer("the brown armchair", ctx).entity_ids == (1,)
    assert LEXICAL.answer("the whitish armchair", ctx).entity_ids == (2,)
    assert LEXICAL.answer("the armchair under the navy pillow", ctx).entity_ids == (2,)
    red = LEXICAL.answer("the red pillow", ctx)
    assert red.entity_ids == () and red.nothing_fits
    stored = {a.key: a.value for a in ctx.graph.get_entity(3).attributes}
    assert stored == {"rgb": "#142882", "color": "blue"}


@pytest.mark.parametrize(
    ("rgb", "word", "other"),
    [((0, 255, 0), "white", "green"), ((255, 0, 0), "yellow", "red"),
     ((255, 0, 255), "black", "purple")],
)  # fmt: skip
def test_a_vivid_colour_contradicts_a_word_far_from_it(
    rgb: tuple[int, int, int], word: str, other: str
) -> None:
    # a saturated colour is far from every colour name, its own included: the scene
    # contradicts a word by the word's own distance, not by how much farther it is than
    # the colour's nearest name (which let "the white chair" pick a vivid green one)
    doc = _coloured(("chair", 0, rgb), ("table", 2, rgb))
    ctx = SceneContext(objects_to_scene_graph(parse_objects(doc)))
    answer = LEXICAL.answer(f"the {word} chair", ctx)
    assert answer.entity_ids == () and answer.nothing_fits
    assert f"contradicts {word!r}" in answer.explanation
    assert LEXICAL.answer(f"the {other} chair", ctx).entity_ids == (1,)


def test_the_rest_of_the_scene_shows_what_a_colour_word_looks_like() -> None:
    # two brown chairs (36 from "black": within the distance alone) in a room whose
    # monitor, bin and tv measure black: the scene's lighting shows black, no chair is
    # black, "the black chair" answers nothing; the same chairs in a room with nothing
    # blacker keep "the black chair" to the darker one
    brown, darker = (150, 110, 70), (120, 85, 55)
    black = (30, 30, 32)
    room = _coloured(("chair", 0, brown), ("chair", 1, darker), ("monitor", 2, black),
                     ("trash can", 3, black), ("tv", 4, black), ("table", 5, brown))  # fmt: skip
    ctx = SceneContext(objects_to_scene_graph(parse_objects(room)))
    answer = LEXICAL.answer("the black chair", ctx)
    assert answer.entity_ids == () and answer.nothing_fits
    assert "contradicts 'black'" in answer.explanation
    assert "3 of 4 other objects are nearer to black" in answer.explanation
    assert LEXICAL.answer("the chair near the black monitor", ctx).entity_ids == (2,)
    dim = _coloured(("chair", 0, brown), ("chair", 1, darker), ("monitor", 2, brown),
                    ("trash can", 3, brown), ("tv", 4, black), ("table", 5, brown))  # fmt: skip
    ctx = SceneContext(objects_to_scene_graph(parse_objects(dim)))
    kept = LEXICAL.answer("the black chair", ctx)
    assert kept.entity_ids == (2,) and not kept.nothing_fits, kept.explanation


def test_of_several_colour_words_one_the_scene_contradicts_is_left_out() -> None:
    # "the green and blue chairs" where no chair is blue, "a blue-grey blanket" where the
    # blanket is grey: the colour that fits is used, the other noted; when every colour
    # word is contradicted, nothing fits
    doc = _coloured(("chair", 0, (40, 150, 60)), ("chair", 1, (200, 200, 200)),
                    ("table", 3, (120, 80, 50)), ("table", 6, (120, 80, 50)),
                    ("blanket", 4, (128, 128, 128)))  # fmt: skip
    ctx = SceneContext(objects_to_scene_graph(parse_objects(doc)))
    answer = LEXICAL.answer("the table closest to the green and blue chairs", ctx)
    assert answer.entity_ids == (3,) and not answer.nothing_fits
    assert "nothing here is blue; the word was not used" in answer.explanation
    assert LEXICAL.answer("the blue-grey blanket", ctx).entity_ids == (5,)
    none = LEXICAL.answer("the table closest to the red and navy chairs", ctx)
    assert none.entity_ids == () and none.nothing_fits


def test_the_colour_of_a_part_the_scene_does_not_hold_ranks_its_object() -> None:
    # three monitors, one measured pink: "the monitor with a pink screen" (no screen in the
    # objects) is the pink one; a part is a share of its object's colour, so a part's
    # colour no monitor is near ranks them and never answers "none"
    doc = _coloured(("monitor", 0, (40, 40, 42)), ("monitor", 1, (203, 83, 164)),
                    ("monitor", 2, (70, 70, 75)), ("desk", 4, (120, 80, 50)))  # fmt: skip
    ctx = SceneContext(objects_to_scene_graph(parse_objects(doc)))
    pink = LEXICAL.answer("the monitor with a pink screen", ctx)
    assert pink.entity_ids == (2,), pink.explanation
    assert "'pink screen' is part of it: pink, 1 of 3 candidates by colour" in pink.explanation
    green = LEXICAL.answer("the monitor with a bright green screen", ctx)
    assert len(green.entity_ids) == 1 and not green.nothing_fits, green.explanation


@pytest.mark.shared_data
def test_needs_on_scene0000(reasoner: OfflineReasoner) -> None:
    from causalsplat.bench._reasoning_referit import objects_document
    from tests.conftest import shared_data_path

    root = shared_data_path("referit3d_scannet_objects")
    ctx = SceneContext(
        objects_to_scene_graph(parse_objects(objects_document("scene0000_00", root)))
    )
    everything = _non_structural(ctx)

    def cats(text: str) -> set[str]:
        answer = reasoner.answer(text, ctx)
        assert len(answer.entity_ids) < everything // 2, text
        return set(answer.categories)

    assert cats("How can I keep my drinks cold?") == {"refrigerator"}
    assert cats("How can I wash my hands?") == {"sink"}
    assert cats("where can I store my dishes?") != {"refrigerator"}
    # no plant in this apartment: nothing needs watering (the sink gives water)
    watering = reasoner.answer("which thing needs watering?", ctx)
    assert watering.entity_ids == () and watering.nothing_fits
    assert cats("What can I use to heat up my lunch?") <= {"microwave", "toaster oven"}
    assert "sink" not in cats("I just washed my hands, where can I dry them?")
    assert "shower" not in cats("I need warm air to dry my hair")
    for text in ("which thing needs watering?", "where can the baby play?", "I'm hot"):
        cats(text)
    # what the need acts on (the paper) is not what would meet it best anywhere: held to
    # paper's score, the trash cans fell short and nothing was answered
    assert cats("I need to throw this paper away.") == {"trash can"}
    # too hot to work: the need is to cool down, not a desk to work at
    assert cats("it's too hot to work in here") in ({"window"}, {"shower"})
    # where a thing belongs is a need for a place for it; "go to <verb>" an infinitive
    assert cats("where do dirty clothes go") == {"laundry basket"}
    assert cats("where do I go to shower?") == {"shower"}


def test_colour_programs_agree_on_every_executor(tmp_path: Path) -> None:
    from causalsplat import open_store

    doc = _coloured(("armchair", 0, (120, 80, 50)), ("armchair", 3, (225, 222, 215)),
                    ("armchair", 6, (110, 75, 48)))  # fmt: skip
    path = tmp_path / "rgb.json"
    path.write_text(__import__("json").dumps(doc))
    with open_store(f"sqlite:///{tmp_path / 's.db'}") as store:
        scene = store.ingest_objects(path)
        answer = scene.ask("all the chocolate armchairs")
        assert "rgb=#" in answer.program.to_text()
        results = {ex: scene.run(answer.program, executor=ex).answer
                   for ex in ("networkx", "sql", "sparql")}  # fmt: skip
        assert set(results.values()) == {(1, 3)}


def _grey_armchairs(lighter: int, darker: int) -> SceneContext:
    """Two grey armchairs (both named gray), the darker one larger."""
    doc = _coloured(("armchair", 0, (lighter,) * 3), ("armchair", 3, (darker,) * 3))
    doc["objects"][1]["size"] = [1.2, 1.2, 1.0]
    return SceneContext(objects_to_scene_graph(parse_objects(doc)))


@pytest.mark.parametrize(
    ("darker", "how"),
    [(95, "1 of 2 candidates by colour"),  # far apart in colour: the word keeps one
     (140, "nearest in colour")],  # within COLOUR_MARGIN: both kept, the nearer taken
)  # fmt: skip
def test_of_several_left_for_one_the_nearest_in_colour_is_taken(darker: int, how: str) -> None:
    # "the white armchair" is the lighter one, not the larger one, though neither is
    # called white
    ctx = _grey_armchairs(150, darker)
    answer = LEXICAL.answer("the white armchair", ctx)
    assert answer.entity_ids == (1,) and how in answer.explanation
    assert LEXICAL.answer("the black armchair", ctx).entity_ids == (2,)
    assert LEXICAL.answer("the armchair", ctx).entity_ids == (2,)  # no colour: the largest


def test_a_basic_colour_word_keeps_a_candidate_whose_colour_another_term_names() -> None:
    # a shaded grey chair's measured colour is named black, as is a black chair's; no
    # chair is named gray. "the gray chair next to the table" is the grey one, though the
    # black one is nearer the table: the word narrows by distance, not by names
    doc = _coloured(("chair", 0, (55, 55, 55)), ("chair", 3, (10, 10, 10)),
                    ("chair", -3, (200, 30, 30)), ("table", 4, (120, 80, 50)))  # fmt: skip
    ctx = SceneContext(objects_to_scene_graph(parse_objects(doc)))
    assert [ctx.by_id[i].attribute_values("color") for i in (1, 2)] == [("black",)] * 2
    answer = LEXICAL.answer("the gray chair next to the table", ctx)
    assert answer.entity_ids == (1,) and "1 of 3 candidates by colour" in answer.explanation
    assert LEXICAL.answer("the chair next to the table", ctx).entity_ids == (2,)


def _three_couches() -> SceneContext:
    """A dark brown, a light brown and a pale blue couch, the pale blue one the largest."""
    doc = _coloured(("couch", 0, (60, 38, 22)), ("couch", 3, (181, 140, 100)),
                    ("couch", 6, (150, 190, 215)))  # fmt: skip
    doc["objects"][2]["size"] = [1.6, 1.0, 0.8]
    return SceneContext(objects_to_scene_graph(parse_objects(doc)))


@pytest.mark.parametrize(
    ("text", "expected"),
    [("the dark brown couch", (1,)), ("the light brown couch", (2,)),
     ("the pale blue couch", (3,)), ("the dark couch", (1,)),
     ("the dark-coloured couch", (1,)), ("this couch is dark", (1,)),
     ("the light colored couch", (3,)), ("the couch", (3,))],
)  # fmt: skip
def test_shades_make_a_colour_lighter_or_darker_and_alone_name_its_lightness(
    text: str, expected: tuple[int, ...]
) -> None:
    answer = LEXICAL.answer(text, _three_couches())
    assert answer.entity_ids == expected, answer.explanation


@pytest.mark.parametrize(
    ("text", "expected"),
    [("the darkest stool", (1,)), ("the darker stool", (1,)), ("the lightest stool", (3,)),
     ("the lighter of the stools", (3,)), ("the stool that is darker", (1,)),
     ("the dark stool", (1, 2))],
)  # fmt: skip
def test_a_compared_shade_takes_the_darkest_or_lightest_alone(
    text: str, expected: tuple[int, ...]
) -> None:
    # brown stools of L* 26, 33 and 45: "dark" keeps those within 10 of the darkest (then
    # one of them is taken), "darker" and "darkest" the darkest alone
    ctx = SceneContext(objects_to_scene_graph(parse_objects(_coloured(
        ("stool", 0, (88, 57, 30)), ("stool", 3, (107, 72, 39)), ("stool", 6, (126, 100, 70))
    ))))  # fmt: skip
    answer = LEXICAL.answer(text, ctx)
    assert set(answer.entity_ids) <= set(expected) and answer.entity_ids, answer.explanation
    if len(expected) == 1:
        assert answer.entity_ids == expected


def test_the_light_is_still_a_thing() -> None:
    # "light" before a verb is the lamp, not a shade of the next word
    doc = _coloured(("light", 0, (240, 240, 230)), ("couch", 3, (60, 38, 22)))
    ctx = SceneContext(objects_to_scene_graph(parse_objects(doc)))
    assert LEXICAL.parse("the light is next to the couch", ctx).target.categories == ("light",)


@pytest.mark.parametrize(
    ("text", "expected"),
    [("the brown couch, not the light one", (1,)),
     ("all the couches that are not blue", (1, 2)),
     ("the brown couch not the dark brown couch", (2,)),
     ("the couch that is not green", (3,))],  # the word drops none: nothing said of them
)  # fmt: skip
def test_a_negated_colour_drops_the_one_it_names(text: str, expected: tuple[int, ...]) -> None:
    answer = LEXICAL.answer(text, _three_couches())
    assert answer.entity_ids == expected, answer.explanation


def _room(*labels: str) -> SceneContext:
    """Objects of the given labels, 1 m apart on the floor."""
    document = {"scene_id": "room", "objects": [
        {"id": k, "label": label, "center": [1.2 * k, 0, 0.4], "size": [0.6, 0.6, 0.8]}
        for k, label in enumerate(labels, start=1)
    ]}  # fmt: skip
    return SceneContext(objects_to_scene_graph(parse_objects(document)))


def test_what_the_best_thing_is_a_kind_of_may_stand_for_it(reasoner: OfflineReasoner) -> None:
    # what would fit best is an alarm clock (absent); the room's clock may well be one, and
    # does what it does: it passes the verb gate though it scores below what it asks
    room = _room("bed", "clock", "nightstand", "lamp", "desk", "shower")
    answer = reasoner.answer("I need a way to wake up early", room)
    assert answer.categories == ("clock",), answer.explanation
    assert "best anywhere: alarm clock" in answer.explanation
    assert "which clock may be" in answer.explanation
    # without the general name nothing here fits
    none = reasoner.answer("I need a way to wake up early", _room("bed", "nightstand", "lamp"))
    assert none.entity_ids == () and none.nothing_fits, none.explanation


def test_a_kind_of_the_reference_passes_where_it_alone_decides() -> None:
    # on scene0000_00 the clock scores 0.34 against the alarm clock's 0.58: below the
    # share the verb gate asks, answered nothing before (a DDN *train* need)
    from causalsplat.bench._reasoning_referit import objects_document
    from tests.conftest import shared_data_path

    root = shared_data_path("referit3d_scannet_objects")
    ctx = SceneContext(
        objects_to_scene_graph(parse_objects(objects_document("scene0000_00", root)))
    )
    answer = OfflineReasoner(embeddings=True).answer("I need a way to wake up in the morning.", ctx)
    assert answer.categories == ("clock",), answer.explanation
    assert "which clock may be" in answer.explanation


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("I'd like an appliance to get my wet laundry dry", "clothes dryer"),
        ("we need a gadget to get the laundry clean", "washing machine"),
        ("I need a towel to dry my face", "towel"),  # the noun names what is wanted
    ],
)
def test_a_kind_noun_before_a_purpose_leaves_the_choice_to_the_purpose(
    reasoner: OfflineReasoner, text: str, expected: str
) -> None:
    room = _room("washing machine", "clothes dryer", "towel", "laundry basket")
    answer = reasoner.answer(text, room)
    assert answer.categories == (expected,), answer.explanation


def test_a_colour_in_a_question_of_every_one_keeps_those_it_names() -> None:
    # four brown stools and a white one: "the green stool" takes the one nearest to green
    # (a scan's colours are dim), but "which stools are green?", "how many green stools"
    # and "is there a green stool?" ask of each one whether it is green
    doc = _coloured(("stool", 0, (126, 90, 50)), ("stool", 1, (107, 72, 39)),
                    ("stool", 2, (92, 62, 34)), ("stool", 3, (88, 57, 30)),
                    ("stool", 4, (225, 222, 215)))  # fmt: skip
    ctx = SceneContext(objects_to_scene_graph(parse_objects(doc)))
    assert LEXICAL.answer("how many green stools are there?", ctx).value == 0
    assert LEXICAL.answer("is there a green stool?", ctx).value is False
    assert LEXICAL.answer("which stools are green?", ctx).entity_ids == ()
    assert LEXICAL.answer("how many brown stools are there?", ctx).value == 4
    assert LEXICAL.answer("is there a white stool?", ctx).value is True
    assert LEXICAL.answer("all the white stools", ctx).entity_ids == (5,)
    assert len(LEXICAL.answer("the green stool", ctx).entity_ids) == 1
