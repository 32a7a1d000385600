"""The VLM backend: a vision-language model writes the program, the executor runs it.

One request per instruction to an OpenAI-compatible chat-completions server
(:mod:`causalsplat.openai_compat`), with the prompt templates of ``prompts/`` (the system
prompt lists the ops and relations; the user prompt holds the compact scene graph of
:mod:`causalsplat.reason._graph_text` and the instruction) and structured output:
``response_format`` is a strict ``json_schema`` (:func:`reply_schema`) of ``{"program":
<the program's strict schema>, "target_ids": [...], "explanation": "..."}`` (the method's
three stages in one reply). Everything a model could run on with is bounded: at most
:data:`~queries.model.MAX_STEPS` steps, :data:`MAX_TARGET_IDS` ids, and string lengths.

Every reply is checked: cut off by its token budget
(:class:`~causalsplat.openai_compat.VLMTruncatedError`), not JSON, not of the schema or not
a valid program (:class:`~queries.QueryValidationError`), naming a category, attribute or
affordance the scene does not hold, or an entity id not in the graph. One retry changes
what made the first reply fail: after a cut-off reply it asks again for a shorter answer
with twice the token budget (:func:`~causalsplat.openai_compat.retry_budget`); after any
other failure it feeds the error back. A second failure, a timeout, an HTTP error or a
replay miss hand the instruction to the fallback reasoner (the offline one by default),
and the :class:`~causalsplat.reason.answer.Answer` says so (``reasoner="offline"``,
``requested="vlm"``, ``fallback=<why>``, naming the error type and both replies'
problems). With ``fallback=False`` the typed error is raised instead. The program (not
the model's ``target_ids``) decides the answer; when the two disagree the explanation
says so.
"""

from __future__ import annotations

import json
from dataclasses import replace
from importlib import resources
from pathlib import Path
from string import Template
from typing import TYPE_CHECKING, Any

from causalsplat.openai_compat import (
    ChatClient,
    VLMConfig,
    VLMError,
    VLMReplyError,
    VLMTruncatedError,
    check_finished,
    retry_budget,
)
from causalsplat.openai_compat.client import ChatReply, Message, with_note
from causalsplat.reason._graph_text import graph_text
from causalsplat.reason.answer import Answer, make_answer
from causalsplat.reason.context import SceneContext
from causalsplat.reason.errors import ReasonError
from causalsplat.reason.ground import Grounded
from causalsplat.reason.offline import scored_candidates
from causalsplat.reason.reasoner import Reasoner
from graph_store.types import RelationType
from queries import OP_SPECS, GraphQuery, Op, QueryError, QueryValidationError
from queries.schema import graph_query_schema_by_op, strict_schema
from queries.semantics import normalise_text, split_attribute

if TYPE_CHECKING:
    from causalsplat.reason.offline import OfflineReasoner

_GRAPH_KEY = "vlm:graph-text"
#: Most ids a reply's ``target_ids`` may list (they only cross-check the program).
MAX_TARGET_IDS = 16
#: Longest explanation kept, in characters (the schema's bound; a longer one is cut).
MAX_EXPLANATION_LENGTH = 200
#: Bounds of a reply's program, tighter than the query language's own (64 steps, values of
#: 512 characters, 8 inputs): a grammar-constrained server fills what the schema allows,
#: and a small model under strict mode (every property present) writes every step in full.
#: Measured with SmolLM2-135M-Instruct under llama.cpp: about 150 tokens a filled step
#: (whitespace and digits included), so a reply at these bounds is about 1,300 tokens:
#: cut at the default 1,024, whole on the retry's 2,048. 8 steps hold 85 of the 86
#: programs the offline reasoner writes for the ScanNet scene0000_00 queries.
MAX_REPLY_STEPS = 8
MAX_REPLY_VALUE_LENGTH = 48
MAX_REPLY_INPUTS = 4


def _template(name: str) -> Template:
    path = resources.files("causalsplat.reason").joinpath("prompts", name)
    return Template(path.read_text(encoding="utf-8"))


def reply_schema() -> dict[str, Any]:
    """The JSON Schema of a reply (the program, the target ids, an explanation), valid
    under OpenAI's strict mode (:func:`queries.schema.strict_schema`)."""
    rest = strict_schema(
        {
            "type": "object",
            "properties": {
                "target_ids": {
                    "type": "array",
                    "items": {"type": "integer", "minimum": 0},
                    "maxItems": MAX_TARGET_IDS,
                    "description": "Ids of the entities the program selects (at most"
                    f" {MAX_TARGET_IDS}).",
                },
                "explanation": {
                    "type": "string",
                    "maxLength": MAX_EXPLANATION_LENGTH,
                    "description": "One or two sentences.",
                },
            },
            "required": ["target_ids", "explanation"],
        }
    )
    return {
        "type": "object",
        "properties": {"program": reply_program_schema(), **rest["properties"]},
        "required": ["program", "target_ids", "explanation"],
        "additionalProperties": False,
    }


def reply_program_schema() -> dict[str, Any]:
    """The program's strict-mode schema with the reply's bounds (:data:`MAX_REPLY_STEPS`,
    :data:`MAX_REPLY_VALUE_LENGTH`, :data:`MAX_REPLY_INPUTS`)."""
    schema = graph_query_schema_by_op()
    schema.pop("title", None)
    props = schema["properties"]
    props["steps"]["maxItems"] = MAX_REPLY_STEPS
    props["answer_step"]["maximum"] = MAX_REPLY_STEPS - 1
    for step in props["steps"]["items"]["anyOf"]:
        fields = step["properties"]
        if "value" in fields:
            fields["value"]["maxLength"] = MAX_REPLY_VALUE_LENGTH
        inputs = fields["inputs"]
        inputs["maxItems"] = min(inputs["maxItems"], MAX_REPLY_INPUTS)
    return strict_schema(schema)


def response_format() -> dict[str, Any]:
    return {
        "type": "json_schema",
        "json_schema": {"name": "scene_graph_answer", "schema": reply_schema(), "strict": True},
    }


class VLMReasoner:
    """Program synthesis by a VLM server, with validation, one retry and a fallback.

    Args:
        config: server settings (default: ``VLMConfig.from_env()``).
        client: a ready :class:`~causalsplat.openai_compat.ChatClient` (overrides
            ``config``, ``record`` and ``replay``).
        fallback: the reasoner used when the VLM fails (default: a new offline reasoner);
            ``False`` raises the error instead.
        record / replay: a JSONL file of exchanges to write / to answer from.
        max_entities: most entities shown in the prompt.
    """

    name = "vlm"

    def __init__(
        self,
        *,
        config: VLMConfig | None = None,
        client: ChatClient | None = None,
        fallback: Reasoner | bool = True,
        record: str | Path | None = None,
        replay: str | Path | None = None,
        max_entities: int = 300,
    ) -> None:
        self.client = client or ChatClient(config, record=record, replay=replay)
        if fallback is True:
            from causalsplat.reason.offline import OfflineReasoner

            fallback = OfflineReasoner()
        self.fallback: Reasoner | None = fallback or None
        self.max_entities = max_entities
        self._offline: OfflineReasoner | None = None

    def __repr__(self) -> str:
        return f"VLMReasoner({self.client!r})"

    def answer(self, text: str, ctx: SceneContext) -> Answer:
        from causalsplat.reason.offline import check_instruction

        check_instruction(text)
        ctx.require_categories()
        try:
            program, notes = self.program(text, ctx)
            result = ctx.run(program)
        except (VLMError, QueryError) as exc:
            if self.fallback is None:
                raise
            why = f"{type(exc).__name__}: {exc}"
            answer = self.fallback.answer(text, ctx)
            return replace(
                answer,
                requested=self.name,
                fallback=why,
                explanation=f"the VLM failed ({why}); answered by {answer.reasoner}\n"
                + answer.explanation,
            )
        named = notes.target_ids
        if (
            isinstance(result.answer, tuple)
            and named is not None
            and set(named) != set(result.answer)
        ):
            notes.lines.append(
                f"the model named {sorted(named)}; its program selects"
                f" {list(result.answer)} (the program's answer is kept)"
            )
        explanation = "\n".join([*notes.lines, result.explain()])
        grounded = self._ground(text, ctx)
        candidates = () if grounded is None else scored_candidates(ctx, grounded, result)
        if isinstance(result.answer, tuple):
            picked = {ctx.by_id[i].category for i in result.answer}
            candidates = tuple(replace(c, chosen=c.category in picked) for c in candidates)
        return make_answer(ctx, text, result, explanation=explanation, reasoner=self.name,
                           candidates=candidates)  # fmt: skip

    # -- grounding (the offline stages 1-2, shown to the model) ----------------------------

    def _ground(self, text: str, ctx: SceneContext) -> Grounded | None:
        """The offline grounding of the instruction (the fallback's own reasoner when it is
        an offline one), or ``None`` when it cannot be read."""
        from causalsplat.reason.offline import OfflineReasoner

        offline = self.fallback if isinstance(self.fallback, OfflineReasoner) else None
        if offline is None:
            offline = self._offline = self._offline or OfflineReasoner()
        try:
            return offline.ground(text, ctx)
        except ReasonError:
            return None

    def candidates_text(self, text: str, ctx: SceneContext) -> str:
        """The grounding stage's ranked candidates, one per line, for the prompt: a small
        model chooses among them rather than reading every entity."""
        grounded = self._ground(text, ctx)
        g = None if grounded is None else grounded.target
        if g is None and grounded is not None and grounded.removed:
            g = grounded.removed[0]
        if g is None or not g.candidates:
            return "(none: the instruction names its target, or any entity)"
        lines = []
        for c in g.candidates:
            ids = [e.id for e in ctx.graph.entities if e.category == c.category][:12]
            lines.append(f"{c.category} {c.score:.2f} ids {ids} ({c.evidence})")
        return "\n".join(lines)

    # -- one exchange ----------------------------------------------------------------------

    def messages(self, text: str, ctx: SceneContext) -> list[Message]:
        """The system and user messages for an instruction."""
        graph = ctx.cache.get(_GRAPH_KEY)
        if graph is None:
            graph = ctx.cache[_GRAPH_KEY] = graph_text(ctx.graph, max_entities=self.max_entities)
        ops = "\n".join(f"- {spec.signature}" for spec in OP_SPECS.values())
        relations = ", ".join(r.value for r in RelationType)
        system = _template("system.txt").substitute(ops=ops, relations=relations)
        user = _template("user.txt").substitute(
            graph=graph, instruction=text, candidates=self.candidates_text(text, ctx)
        )
        return [{"role": "system", "content": system}, {"role": "user", "content": user}]

    def program(self, text: str, ctx: SceneContext) -> tuple[GraphQuery, _Notes]:
        """Ask the server for a program (one retry, module docstring); raises a
        ``VLMError`` when the second reply is unusable too."""
        messages = self.messages(text, ctx)
        fmt = response_format()
        budget = self.client.config.max_tokens
        reply = self.client.complete(messages, response_format=fmt, max_tokens=budget)
        first: VLMReplyError
        try:
            return check_reply(reply, ctx, max_tokens=budget)
        except VLMTruncatedError as exc:
            first, budget = exc, retry_budget(budget)
            note = _template("retry_truncated.txt").substitute(
                max_tokens=exc.max_tokens, max_ids=MAX_TARGET_IDS
            )
            messages = with_note(messages, note)
        except VLMReplyError as exc:
            first = exc
            messages = [
                *messages,
                {"role": "assistant", "content": compact_reply(reply.content)},
                {"role": "user", "content": _template("retry.txt").substitute(error=str(exc))},
            ]
        second = self.client.complete(messages, response_format=fmt, max_tokens=budget)
        try:
            program, notes = check_reply(second, ctx, max_tokens=budget)
        except VLMReplyError as exc:
            raise exc.after(first) from exc
        notes.lines.insert(0, f"first reply rejected ({first.reason}); the retry was used")
        return program, notes


class _Notes:
    """What a checked reply says besides the program."""

    def __init__(self, target_ids: list[int] | None, explanation: str) -> None:
        self.target_ids = target_ids
        self.lines = [f"the model: {explanation}"] if explanation else []


def check_reply(
    reply: ChatReply, ctx: SceneContext, *, max_tokens: int | None = None
) -> tuple[GraphQuery, _Notes]:
    """Validate one reply (generated under ``max_tokens``) against the schema and the
    scene (module docstring)."""
    check_finished(reply, max_tokens)
    try:
        data = json.loads(_strip_fences(reply.content))
    except json.JSONDecodeError as exc:
        raise VLMReplyError(f"the reply is not JSON ({exc.msg})", reason="json") from exc
    if not isinstance(data, dict) or "program" not in data:
        raise VLMReplyError("the reply must be a JSON object with a 'program'", reason="schema")
    extra = sorted(set(data) - {"program", "target_ids", "explanation"})
    if extra:
        raise VLMReplyError(f"unexpected keys {extra}", reason="schema")
    try:
        program = GraphQuery.parse(data["program"])
    except QueryValidationError as exc:
        raise VLMReplyError(f"the program is invalid: {exc}", reason="schema") from exc
    _check_names(program, ctx)
    ids = data.get("target_ids")
    if ids is not None:
        if not isinstance(ids, list) or not all(
            isinstance(i, int) and not isinstance(i, bool) for i in ids
        ):
            raise VLMReplyError("'target_ids' must be a list of integers", reason="schema")
        if len(ids) > MAX_TARGET_IDS:
            raise VLMReplyError(
                f"'target_ids' lists {len(ids)} ids; list at most {MAX_TARGET_IDS}, only"
                " those the program selects",
                reason="schema",
            )
        unknown = sorted(i for i in ids if i not in ctx.by_id)
        if unknown:
            raise VLMReplyError(
                f"target_ids {unknown} are not entities of the scene", reason="unknown_id"
            )
    explanation = data.get("explanation") or ""
    if not isinstance(explanation, str):
        raise VLMReplyError("'explanation' must be a string", reason="schema")
    explanation = explanation.strip()
    if len(explanation) > MAX_EXPLANATION_LENGTH:
        explanation = explanation[: MAX_EXPLANATION_LENGTH - 1].rstrip() + "\u2026"
    return program, _Notes(ids, explanation)


def _check_names(program: GraphQuery, ctx: SceneContext) -> None:
    categories = {normalise_text(c) for c in ctx.categories}
    pairs = {(normalise_text(k), normalise_text(v)) for k, v in ctx.attribute_pairs()}
    affordance_key = normalise_text(ctx.config.affordance_key)
    for i, step in enumerate(program.steps):
        value = step.value
        if value is None:
            continue
        if step.op is Op.FILTER_CATEGORY and normalise_text(value) not in categories:
            raise VLMReplyError(
                f"step {i}: category {value!r} is not in the scene"
                f" (categories: {', '.join(sorted(ctx.categories)[:40])})",
                reason="unknown_name",
            )
        if step.op is Op.FILTER_ATTRIBUTE and split_attribute(value) not in pairs:
            raise VLMReplyError(
                f"step {i}: attribute {value!r} is not in the scene", reason="unknown_name"
            )
        if step.op is Op.FILTER_AFFORDANCE and (affordance_key, normalise_text(value)) not in pairs:
            raise VLMReplyError(
                f"step {i}: affordance {value!r} is not in the scene", reason="unknown_name"
            )


def compact_reply(content: str) -> str:
    """A rejected reply as the retry repeats it: re-serialised without indentation when it
    is JSON (a small model writes two-space indented JSON, a third of its tokens
    whitespace, and the retry must fit the model's context), as written otherwise."""
    try:
        return json.dumps(json.loads(_strip_fences(content)), ensure_ascii=False)
    except (json.JSONDecodeError, RecursionError):
        return content


def _strip_fences(content: str) -> str:
    text = content.strip()
    if text.startswith("```"):
        text = text.split("\n", 1)[1] if "\n" in text else ""
        text = text.rsplit("```", 1)[0]
    return text.strip()
