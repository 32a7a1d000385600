"""The offline reasoner: deterministic, no network, no GPU, no torch.

Three stages, as in the method: :func:`~causalsplat.reason.parse.parse_instruction`
(stage 1: what is asked, which phrases name what), :class:`~causalsplat.reason.topology.Planner`
(stage 2: anchors and relations as program steps) and
:func:`~causalsplat.reason.decide.decide` (stage 3: the target ids). The program is run by
the scene's executor; the :class:`~causalsplat.reason.answer.Answer` carries it, its
result and an explanation.

Words are matched to the scene's categories through the shipped WordNet lexicon
(:mod:`causalsplat.reason.lexicon`); with ``embeddings=True`` (or ``"auto"`` and the
``embed`` extra installed) affordance matching also uses sentence embeddings.
"""

from __future__ import annotations

from typing import Literal

from causalsplat.reason._builder import ProgramBuilder
from causalsplat.reason._mentions import CategoryIndex
from causalsplat.reason.answer import Answer, make_answer
from causalsplat.reason.context import SceneContext
from causalsplat.reason.decide import decide
from causalsplat.reason.embed import TextEmbedder, embeddings_available, load_embedder
from causalsplat.reason.lexicon import Lexicon, load_lexicon
from causalsplat.reason.parse import Instruction, parse_instruction

EmbeddingChoice = bool | Literal["auto"]
_INDEX_KEY = "offline:category-index"


class OfflineReasoner:
    """Rule-based reasoning over a stored scene graph (module docstring).

    Args:
        embeddings: ``False`` (default): lexical matching only. ``True``: also sentence
            embeddings; raises ``ImportError`` with the install hint when the ``embed``
            extra is missing. ``"auto"``: embeddings when the extra is installed.
        lexicon: a lexicon to use instead of the shipped one.
    """

    name = "offline"

    def __init__(self, *, embeddings: EmbeddingChoice = False, lexicon: Lexicon | None = None):
        self._lexicon = lexicon
        self.embedder: TextEmbedder | None = None
        if embeddings is True or (embeddings == "auto" and embeddings_available()):
            self.embedder = load_embedder()

    def __repr__(self) -> str:
        return f"OfflineReasoner(embeddings={self.embedder is not None})"

    @property
    def lexicon(self) -> Lexicon:
        if self._lexicon is None:
            self._lexicon = load_lexicon()
        return self._lexicon

    def index(self, ctx: SceneContext) -> CategoryIndex:
        """The scene's category index (built once per scene context)."""
        index = ctx.cache.get(_INDEX_KEY)
        if index is None or index.lexicon is not self.lexicon:
            key = ctx.config.affordance_key
            words = frozenset(
                v.lower() for k, v in ctx.attribute_pairs() if " " not in v and k != key
            )
            index = ctx.cache[_INDEX_KEY] = CategoryIndex(ctx.categories, self.lexicon, words)
        return index  # type: ignore[no-any-return]

    def parse(self, text: str, ctx: SceneContext) -> Instruction:
        """Stage 1 only."""
        return parse_instruction(text, self.index(ctx))

    def answer(self, text: str, ctx: SceneContext) -> Answer:
        """Answer ``text`` on the scene; raises
        :class:`~causalsplat.reason.errors.InstructionError` when it names nothing there."""
        instruction = self.parse(text, ctx)
        builder = ProgramBuilder(ctx)
        decision = decide(builder, instruction, self.lexicon, self.embedder)
        result = ctx.run(decision.program)
        lines = [f"read as: {_describe(instruction)}", *decision.notes, result.explain()]
        return make_answer(ctx, text, result, explanation="\n".join(lines), reasoner=self.name)


def _describe(ins: Instruction) -> str:
    if ins.kind == "counterfactual":
        return f"counterfactual: remove {', '.join(np.text for np in ins.removed)}"
    if ins.kind == "action":
        return f"an action: {' '.join(ins.action)}"
    target = ins.target
    assert target is not None
    parts = [f"{ins.kind} {target.text!r}"]
    for c in target.constraints:
        neg = "not " if c.negated else ""
        parts.append(f"{neg}{c.kind} {' and '.join(repr(a.text) for a in c.anchors)}")
    if target.extremes:
        parts.append(f"{target.extremes[0][1]} {target.extremes[0][0]}")
    if target.side:
        parts.append(f"side {target.side}" + (f" #{target.ordinal}" if target.ordinal else ""))
    if ins.viewpoint is not None:
        verb = "standing at" if ins.standing_at else "facing"
        parts.append(f"{verb} {ins.viewpoint.text!r}")
    return "; ".join(parts)
