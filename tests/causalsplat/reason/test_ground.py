"""Stage 2, grounding: what a need or an unnamed phrase is read as, and why."""

from __future__ import annotations

import numpy as np
import pytest

from causalsplat.objects import objects_to_scene_graph, parse_objects
from causalsplat.reason import SceneContext
from causalsplat.reason._builder import ProgramBuilder
from causalsplat.reason.embed import embeddings_available
from causalsplat.reason.ground import (
    DESCRIBED,
    FITS,
    UNSPECIFIC,
    describe,
    facts_for,
    gloss_of,
)
from causalsplat.reason.knowledge import load_knowledge
from causalsplat.reason.lexicon import load_lexicon
from causalsplat.reason.meaning import (
    VECTORS_MODEL,
    EmbeddingMeaning,
    LexicalMeaning,
    QueryAdapter,
    shipped_adapter,
    shipped_digest,
    shipped_vectors,
    texts_digest,
)
from causalsplat.reason.offline import OfflineReasoner
from queries import Op
from queries.model import Metric

LEXICAL = OfflineReasoner(embeddings=False)


def _scene(*objects: tuple[int, str, tuple[float, float, float]], **attrs: object) -> SceneContext:
    doc = {
        "scene_id": "flat",
        "objects": [
            {
                "id": i,
                "label": label,
                "center": list(c),
                "size": [0.6, 0.6, 0.6],
                **({"attributes": attrs[label]} if label in attrs else {}),
            }
            for i, label, c in objects
        ],
    }
    return SceneContext(objects_to_scene_graph(parse_objects(doc)))


FLAT = _scene(
    (1, "sink", (0, 0, 0.9)),
    (2, "bed", (4, 0, 0.3)),
    (3, "refrigerator", (0, 3, 0.9)),
    (4, "towel", (0.5, 0, 1.2)),
    (5, "microwave", (1, 3, 1.0)),
    (6, "object", (2, 2, 0.3)),
    (7, "floor", (2, 2, -0.05)),
    (8, "towel rack", (0.8, 0, 1.2)),
    (9, "bowl", (1, 2.5, 0.9)),
)


def test_a_can_is_a_container_before_it_is_a_toilet() -> None:
    lex = load_lexicon()
    assert "container" in (gloss_of("can", lex) or "")
    assert "toilet" not in (gloss_of("can", lex) or "")


def test_categories_find_their_facts_by_name_base_form_or_head() -> None:
    kb, lex = load_knowledge(), load_lexicon()
    assert facts_for("fridge", kb, lex).name == "refrigerator"  # type: ignore[union-attr]
    assert facts_for("kitchen cabinets", kb, lex) is not None
    assert facts_for("wooden chair", kb, lex).name == "chair"  # type: ignore[union-attr]
    assert facts_for("qwerty", kb, lex) is None
    texts = describe("fridge", lex, kb, [("affordance", "chill drinks"), ("color", "red")])
    assert texts[0] == "fridge" and "fridge: you can chill drinks" in texts
    assert not any("red" in t for t in texts)  # colours do not describe what a thing is for
    assert any(t.startswith("refrigerator: used for") for t in texts)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("I need a place to keep my food cold.", "refrigerator"),
        ("where can I wash my hands?", "sink"),
        ("I am exhausted and want to lie down for the night", "bed"),
        ("I need to dry myself off", "towel"),
        ("where can I heat up a bowl of soup quickly?", "microwave"),
    ],
)
def test_needs_by_word_overlap(text: str, expected: str) -> None:
    answer = LEXICAL.answer(text, FLAT)
    assert answer.categories and set(answer.categories) == {expected}, answer.explanation
    assert answer.query_type == "commonsense"
    assert answer.candidates[0].category == expected and answer.candidates[0].chosen


def test_unspecific_labels_and_the_room_itself_never_answer_a_need() -> None:
    grounded = LEXICAL.ground("I need something to walk on", FLAT)
    assert grounded.target is not None
    ranked = {c.category for c in grounded.target.candidates}
    assert "object" in UNSPECIFIC and not ranked & {"object", "floor"}
    # named outright, the floor is an answer like any other
    assert LEXICAL.answer("the floor", FLAT).categories == ("floor",)


def test_what_the_need_acts_on_is_scored_without_its_own_name() -> None:
    grounded = LEXICAL.ground("I need something to hang my towels", FLAT)
    g = grounded.target
    assert g is not None and g.chosen == ("towel rack",)
    towel = [c for c in g.candidates if c.category == "towel"]
    assert not towel or (towel[0].acted_on > 0.9 and towel[0].score < g.candidates[0].score)
    # after a preposition the named thing is where the need is met, not what it acts on
    sit = LEXICAL.ground("I want to lie down on the bed", FLAT).target
    assert sit is not None and sit.chosen == ("bed",)


def test_a_noun_naming_nothing_here_fits_nothing_unless_its_meaning_is_close() -> None:
    answer = LEXICAL.answer("the piano", FLAT)
    assert answer.entity_ids == () and "nothing here fits" in answer.explanation
    assert [s.op for s in answer.program.steps] == [Op.SCENE, Op.DIFFERENCE]
    assert DESCRIBED > FITS


def test_stored_affordances_select_entities_across_categories() -> None:
    ctx = _scene(
        (1, "crate", (0, 0, 0.3)),
        (2, "bench", (2, 0, 0.3)),
        (3, "lamp", (4, 0, 0.8)),
        crate={"affordance": ["sit", "store items"]},
        bench={"affordance": ["sit"]},
        lamp={"affordance": ["illuminate"]},
    )
    answer = LEXICAL.answer("where can I sit down?", ctx)
    assert answer.entity_ids == (1, 2)
    assert [s.op for s in answer.program.steps][-1] == Op.FILTER_AFFORDANCE
    assert "stored affordance 'sit'" in answer.explanation


def test_the_builder_takes_the_language_enums_only() -> None:
    b = ProgramBuilder(FLAT)
    assert b.add(Op.FILTER_CATEGORY, 0, value="bed") == 1
    with pytest.raises(TypeError, match=r"queries\.Op"):
        b.add("filter_category", 0, value="bed")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="Metric"):
        b.add(Op.ARGMIN, 1, metric="distance")  # type: ignore[arg-type]
    assert b.add(Op.ARGMIN, 1, metric=Metric.DISTANCE) == 2


def test_lexical_meaning_is_word_overlap() -> None:
    scorer = LexicalMeaning(load_lexicon())
    s = scorer.scores("where can I sleep", ["bed: used for sleeping at night", "sink"])
    assert s.shape == (2,) and s[0] > s[1] == 0.0


def test_shipped_vectors_match_the_table() -> None:
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
    from make_knowledge_vectors import knowledge_texts

    shipped = shipped_vectors()
    assert shipped is not None, "run scripts/make_knowledge_vectors.py"
    texts, vectors = shipped
    assert texts_digest(list(texts)) == texts_digest(knowledge_texts()), (
        "the knowledge table or the lexicon changed: run scripts/make_knowledge_vectors.py"
    )
    assert vectors.shape == (len(texts), 384) and VECTORS_MODEL == "all-MiniLM-L6-v2"
    assert np.allclose(np.linalg.norm(vectors, axis=1), 1.0, atol=1e-3)


@pytest.mark.skipif(not embeddings_available(), reason="embed extra not installed")
def test_shipped_vectors_are_the_models_own() -> None:
    from causalsplat.reason.embed import load_embedder

    texts, vectors = shipped_vectors()  # type: ignore[misc]
    picks = list(range(0, len(texts), max(1, len(texts) // 25)))
    fresh = load_embedder().encode([texts[i] for i in picks])
    assert np.abs(fresh - vectors[picks]).max() < 2e-3  # int8 storage, a scale per row
    scorer = EmbeddingMeaning(load_embedder())
    s = scorer.scores("I need somewhere to keep food cold", [texts[i] for i in picks[:3]])
    assert s.shape == (3,) and np.all(np.isfinite(s))


@pytest.mark.skipif(not embeddings_available(), reason="embed extra not installed")
def test_needs_with_embeddings() -> None:
    reasoner = OfflineReasoner(embeddings=True)
    for text, expected in (
        ("I need a place to keep my food cold.", "refrigerator"),
        ("where can I wash my hands?", "sink"),
        ("where can I heat up a bowl of soup quickly?", "microwave"),
        ("I am exhausted and want to lie down for the night", "bed"),
    ):
        answer = reasoner.answer(text, FLAT)
        assert set(answer.categories) == {expected}, (text, answer.explanation)
        assert "(embedding;" in answer.explanation


def test_shipped_adapter_was_trained_on_the_shipped_vectors() -> None:
    adapter = shipped_adapter()
    assert adapter is not None, "run scripts/train_need_adapter.py (needs ../shared/data)"
    assert adapter.digest == shipped_digest(), (
        "the knowledge vectors changed since the need adapter was trained: "
        "run scripts/train_need_adapter.py (needs ../shared/data)"
    )
    assert adapter.u.shape == adapter.v.shape == (384, adapter.rank)
    assert np.isfinite(adapter.u).all() and np.isfinite(adapter.v).all()


def test_query_adapter_moves_the_query_only() -> None:
    rng = np.random.default_rng(0)
    u, v = rng.normal(size=(384, 4)), rng.normal(size=(384, 4))
    q = rng.normal(size=384)
    q /= np.linalg.norm(q)
    moved = QueryAdapter(u, v)(q)
    expected = q + u @ (v.T @ q)  # float64 reference
    assert np.allclose(moved, expected / np.linalg.norm(expected), atol=1e-12)
    assert np.allclose(QueryAdapter(0 * u, v)(q), q)
    with pytest.raises(ValueError, match="one shape"):
        QueryAdapter(u, v[:, :2])

    class Fixed:
        """An embedder whose vectors are fixed: the query is ``q``, a text its own row."""

        def encode(self, texts: list[str]) -> np.ndarray:
            return np.stack([q if t == "query" else texts_rows[t] for t in texts])

    texts_rows = {"a": q, "b": moved}
    plain = EmbeddingMeaning(Fixed(), adapter=None).scores("query", ["a", "b"])
    adapted = EmbeddingMeaning(Fixed(), adapter=QueryAdapter(u, v)).scores("query", ["a", "b"])
    assert plain[0] == pytest.approx(1.0) and adapted[1] == pytest.approx(1.0)
    with pytest.raises(ValueError, match="adapter must be"):
        EmbeddingMeaning(Fixed(), adapter="learned")


def test_a_state_said_of_someone_is_read_as_what_it_calls_for() -> None:
    from causalsplat.reason._text import tokenize
    from causalsplat.reason.ground import _with_states

    def read(text: str) -> str:
        return _with_states(text, tokenize(text))

    assert read("I am so cold") == "I am so in need to warm up"
    assert read("my hands are dirty") == "my hands are in need to wash"
    # said of a thing, not of someone: left as it is
    assert read("I need a place to keep my food cold") == "I need a place to keep my food cold"
    assert read("where do the dirty clothes go") == "where do the dirty clothes go"


@pytest.mark.skipif(not embeddings_available(), reason="embed extra not installed")
def test_being_cold_asks_for_warmth_not_for_what_is_cold() -> None:
    scene = _scene(
        (1, "refrigerator", (0, 3, 0.9)),
        (2, "radiator", (4, 0, 0.4)),
        (3, "table", (2, 2, 0.4)),
        (4, "sink", (0, 0, 0.9)),
    )
    reasoner = OfflineReasoner(embeddings=True)
    assert reasoner.answer("I am freezing", scene).categories == ("radiator",)
    assert reasoner.answer("I need a place to keep my food cold", scene).categories == (
        "refrigerator",
    )
    # with nothing made to warm anyone, still not the fridge
    kitchen = _scene(
        (1, "refrigerator", (0, 3, 0.9)),
        (2, "stove", (2, 3, 0.45)),
        (3, "cup", (2, 2, 0.8)),
        (4, "table", (2, 2, 0.4)),
    )
    assert "refrigerator" not in reasoner.answer("I'm freezing", kitchen).categories
