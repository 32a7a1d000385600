"""The offline reasoner: deterministic, no network, no GPU, no torch.

One sentence goes once through four stages, each reading only the previous one's output:

1. :func:`~causalsplat.reason.parse.parse_instruction` -> :class:`Instruction`: what kind
   of request it is, the target and anchor phrases, relations, the purpose of a need;
2. :meth:`Grounder.ground <causalsplat.reason.ground.Grounder.ground>` -> ``Grounded``:
   every scene category scored against what the instruction asks for (lexicon names,
   the knowledge table of what objects are for, WordNet definitions, sentence embeddings);
3. :func:`~causalsplat.reason.decide.decide` -> ``Decision``: the program (relations,
   modifiers, the decision among several candidates) and the notes explaining it;
4. the scene's executor runs the program, and the :class:`~causalsplat.reason.answer.Answer`
   carries it, its result, the ranked candidates and an explanation.

Meaning is scored with sentence embeddings when the ``embed`` extra is installed
(``embeddings="auto"``, the default), else by WordNet word overlap; ``embeddings=False``
forces the latter. A well-formed sentence never raises: when nothing in the scene fits, the
answer is empty and its explanation and candidates say what came closest.

>>> from causalsplat.objects import objects_to_scene_graph, parse_objects
>>> doc = {"scene_id": "flat", "objects": [
...     {"id": 1, "label": "sink", "center": [0, 0, 0.9], "size": [0.6, 0.5, 0.2]},
...     {"id": 2, "label": "bed", "center": [3, 0, 0.3], "size": [2, 1.6, 0.6]},
...     {"id": 3, "label": "refrigerator", "center": [0, 3, 0.9], "size": [0.8, 0.7, 1.8]}]}
>>> ctx = SceneContext(objects_to_scene_graph(parse_objects(doc)))
>>> reasoner = OfflineReasoner(embeddings=False)
>>> reasoner.answer("I need somewhere to keep the milk cold", ctx).categories
('refrigerator',)
>>> reasoner.answer("where can I wash my hands?", ctx).categories
('sink',)
"""

from __future__ import annotations

from typing import Literal

from causalsplat.reason._builder import ProgramBuilder
from causalsplat.reason._mentions import CategoryIndex
from causalsplat.reason._text import tokenize
from causalsplat.reason.answer import Answer, ScoredCandidate, make_answer
from causalsplat.reason.context import SceneContext
from causalsplat.reason.decide import decide
from causalsplat.reason.embed import TextEmbedder, embeddings_available, load_embedder
from causalsplat.reason.errors import InstructionError
from causalsplat.reason.ground import Grounded, Grounder, Grounding
from causalsplat.reason.knowledge import Knowledge, load_knowledge
from causalsplat.reason.lexicon import Lexicon, load_lexicon
from causalsplat.reason.meaning import EmbeddingMeaning, LexicalMeaning, MeaningScorer
from causalsplat.reason.parse import Instruction, parse_instruction
from queries import QueryResult

EmbeddingChoice = bool | Literal["auto"]
#: Longest instruction, in characters.
MAX_INSTRUCTION = 2000
_INDEX_KEY = "offline:category-index"
_GROUNDER_KEY = "offline:grounder"


class OfflineReasoner:
    """Rule-based reasoning over a stored scene graph (module docstring).

    Args:
        embeddings: ``"auto"`` (default): sentence embeddings when the ``embed`` extra is
            installed; ``True``: required (``ImportError`` with the install hint when the
            extra is missing); ``False``: WordNet word overlap only.
        lexicon: a lexicon to use instead of the shipped one.
        knowledge: a knowledge table to use instead of the shipped one.
        adapter: move an instruction's embedding by the shipped need adapter, learned on
            the DDN train split (:mod:`causalsplat.reason.meaning`); ``False`` scores with
            the sentence model alone. No effect without embeddings.
    """

    name = "offline"

    def __init__(
        self,
        *,
        embeddings: EmbeddingChoice = "auto",
        lexicon: Lexicon | None = None,
        knowledge: Knowledge | None = None,
        adapter: bool = True,
    ):
        self._lexicon = lexicon
        self.adapter = adapter
        self._knowledge = knowledge
        self.uses_embeddings = embeddings is True or (
            embeddings == "auto" and embeddings_available()
        )
        if embeddings is True and not embeddings_available():
            load_embedder()  # raises the install hint now, not at the first need
        self._embedder: TextEmbedder | None = None
        self._scorer: MeaningScorer | None = None

    def __repr__(self) -> str:
        if self.uses_embeddings and not self.adapter:
            return f"OfflineReasoner(embeddings={self.uses_embeddings}, adapter=False)"
        return f"OfflineReasoner(embeddings={self.uses_embeddings})"

    @property
    def embedder(self) -> TextEmbedder | None:
        """The sentence-embedding model (loaded on first use), or ``None``."""
        if self._embedder is None and self.uses_embeddings:
            self._embedder = load_embedder()
        return self._embedder

    @property
    def lexicon(self) -> Lexicon:
        if self._lexicon is None:
            self._lexicon = load_lexicon()
        return self._lexicon

    @property
    def knowledge(self) -> Knowledge:
        if self._knowledge is None:
            self._knowledge = load_knowledge()
        return self._knowledge

    @property
    def scorer(self) -> MeaningScorer:
        if self._scorer is None:
            embedder = self.embedder
            if embedder is not None:
                self._scorer = EmbeddingMeaning(embedder, "shipped" if self.adapter else None)
            else:
                self._scorer = LexicalMeaning(self.lexicon)
        return self._scorer

    def index(self, ctx: SceneContext) -> CategoryIndex:
        """The scene's category index (built once per scene context)."""
        index = ctx.cache.get(_INDEX_KEY)
        if index is None or index.lexicon is not self.lexicon:
            key = ctx.config.affordance_key
            words = frozenset(
                v.lower() for k, v in ctx.attribute_pairs() if " " not in v and k != key
            )
            # another name of the category's own entry (not of an entry it is itself
            # another name of: "round table" takes none of the names of "table")
            aliases = {c: facts.also for c in ctx.categories
                       if (facts := self.knowledge.get(c)) is not None
                       and facts.name == " ".join(c.lower().split())}  # fmt: skip
            index = ctx.cache[_INDEX_KEY] = CategoryIndex(
                ctx.categories, self.lexicon, words, aliases
            )
        return index  # type: ignore[no-any-return]

    def grounder(self, ctx: SceneContext) -> Grounder:
        """The scene's grounding stage (built once per scene context and scorer)."""
        mode = "lexical"
        if self.uses_embeddings:
            mode = "embedding+adapter" if self.adapter else "embedding"
        key = f"{_GROUNDER_KEY}:{mode}"
        grounder = ctx.cache.get(key)
        if grounder is None or grounder.lexicon is not self.lexicon:
            grounder = Grounder(
                ctx, self.index(ctx), self.lexicon, lambda: self.knowledge, lambda: self.scorer
            )
            ctx.cache[key] = grounder
        return grounder  # type: ignore[no-any-return]

    def parse(self, text: str, ctx: SceneContext) -> Instruction:
        """Stage 1 only; raises :class:`InstructionError` for input that is not an
        instruction (see :func:`check_instruction`)."""
        check_instruction(text)
        return parse_instruction(text, self.index(ctx))

    def ground(self, text: str, ctx: SceneContext) -> Grounded:
        """Stages 1 and 2."""
        return self.grounder(ctx).ground(self.parse(text, ctx))

    def answer(self, text: str, ctx: SceneContext) -> Answer:
        """Answer ``text`` on the scene (module docstring)."""
        ctx.require_categories()
        grounded = self.ground(text, ctx)
        decision = decide(ProgramBuilder(ctx), grounded)
        result = ctx.run(decision.program)
        lines = [
            f"read as: {_describe(grounded.instruction)}",
            *decision.explain(result),
            result.explain(),
        ]
        return make_answer(
            ctx,
            text,
            result,
            explanation="\n".join(lines),
            reasoner=self.name,
            candidates=scored_candidates(ctx, grounded, result),
        )


def check_instruction(text: object) -> str:
    """``text`` when it can be an instruction; else :class:`InstructionError`: not a
    string, longer than :data:`MAX_INSTRUCTION` characters, or without a single word
    (empty, blank, control characters or punctuation only)."""
    if not isinstance(text, str):
        raise InstructionError(f"an instruction must be a string, not {type(text).__name__}")
    if len(text) > MAX_INSTRUCTION:
        raise InstructionError(
            f"instruction is {len(text)} characters long; it must be at most {MAX_INSTRUCTION}"
        )
    if not any(t.isalnum() for t in tokenize(text)):
        raise InstructionError("instruction has no words (empty, blank or punctuation only)")
    return text


def scored_candidates(
    ctx: SceneContext, grounded: Grounded, result: QueryResult
) -> tuple[ScoredCandidate, ...]:
    """The answer's ranked candidates: the grounding of its target (or of the first
    removed phrase of a counterfactual), with each category's entities and evidence."""
    g: Grounding | None = grounded.target
    if g is None and grounded.removed:
        g = grounded.removed[0]
    if g is None:
        return ()
    answered = set(result.answer) if isinstance(result.answer, tuple) else None
    out = []
    for c in g.candidates:
        ids = tuple(sorted(e.id for e in ctx.graph.entities if e.category == c.category))
        evidence = [c.evidence]
        chosen = c.category in g.chosen
        if chosen and grounded.instruction.kind != "counterfactual" and answered is not None:
            kept = [i for i in ids if i in answered]
            if len(kept) != len(ids):
                evidence.append(f"{len(kept)} of its {len(ids)} kept by the relations")
        out.append(ScoredCandidate(c.category, c.score, ids, chosen, tuple(evidence)))
    return tuple(out)


def _describe(ins: Instruction) -> str:
    read = "".join(f"; {written!r} read as {read!r}" for written, read in ins.corrected)
    return _reading(ins) + read


def _reading(ins: Instruction) -> str:
    if ins.kind == "counterfactual":
        verb = "move" if ins.moved else "remove"
        return f"counterfactual: {verb} {', '.join(np.text for np in ins.removed)}"
    if ins.kind == "action":
        return f"an action: {' '.join(ins.action)}"
    target = ins.target
    assert target is not None
    parts = [f"{ins.kind} {target.text!r}"]
    for c in target.constraints:
        neg = "not " if c.negated else ""
        parts.append(f"{neg}{c.kind} {' and '.join(repr(a.text) for a in c.anchors)}")
    parts += [f"not {word}" for word in target.not_attributes]
    if target.extremes:
        parts.append(f"{target.extremes[0][1]} {target.extremes[0][0]}")
    parts += [f"not {op} {metric}" for metric, op in target.not_extremes]
    if target.place:
        parts.append(f"place {'not ' if target.place_negated else ''}{target.place}")
    if target.side:
        side = f"{'not ' if target.side_negated else ''}{target.side}"
        parts.append(f"side {side}" + (f" #{target.ordinal}" if target.ordinal else ""))
    if ins.viewpoint is not None:
        verb = "standing at" if ins.standing_at else "facing"
        parts.append(f"{verb} {ins.viewpoint.text!r}")
        if ins.observer_at is not None:
            parts.append(f"from {ins.observer_at.text!r}")
    return "; ".join(parts)
