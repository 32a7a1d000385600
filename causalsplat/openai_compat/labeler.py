"""Entity labels from mask crops by a vision-language model (category, attributes,
affordances), as the method's graph construction uses them.

Each crop (an ``(H, W, 3)`` uint8 or float image of one entity, pixels outside its mask
blanked by the caller) goes to the server as a base64 PNG data URL with the prompt in
``prompts/label_*.txt``, asking for JSON under a strict ``json_schema`` response format
(:func:`queries.schema.strict_schema` of :data:`LABEL_SCHEMA`). A reply that is not JSON
or not of the schema is retried once with the problem fed back; one cut off by its token
budget is retried with twice the budget
(:func:`~causalsplat.openai_compat.client.retry_budget`); a second failure raises
:class:`~causalsplat.openai_compat.errors.VLMReplyError`.

>>> labeler = VLMLabeler(ChatClient(VLMConfig.from_env()))   # doctest: +SKIP
>>> labeler.label_crops([crop])[0].category                  # doctest: +SKIP
'chair'
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from importlib import resources
from string import Template
from typing import Any

import numpy as np

from causalsplat.openai_compat.client import (
    ChatClient,
    ChatReply,
    Message,
    check_finished,
    retry_budget,
    with_note,
)
from causalsplat.openai_compat.errors import VLMReplyError, VLMTruncatedError
from causalsplat.openai_compat.images import image_part
from graph_store import Attribute, AttributeSource
from queries.schema import strict_schema

_KEYS = ("category", "color", "material", "state", "affordances")
LABEL_SCHEMA: dict[str, Any] = {
    "type": "object",
    "properties": {
        "category": {"type": "string", "minLength": 1, "maxLength": 64},
        "color": {"type": "string", "maxLength": 32},
        "material": {"type": "string", "maxLength": 32},
        "state": {"type": "string", "maxLength": 32},
        "affordances": {
            "type": "array",
            "items": {"type": "string", "minLength": 1, "maxLength": 48},
            "maxItems": 8,
        },
    },
    "required": list(_KEYS),
    "additionalProperties": False,
}
RESPONSE_FORMAT: dict[str, Any] = {
    "type": "json_schema",
    "json_schema": {"name": "entity_label", "schema": strict_schema(LABEL_SCHEMA), "strict": True},
}


@dataclass(frozen=True, slots=True)
class EntityLabel:
    """What the model says about one entity.

    ``attributes`` are ``(key, value)`` pairs (``color``, ``material``, ``state``; empty
    values left out); ``affordances`` are verb phrases, lower case.
    """

    category: str
    attributes: tuple[tuple[str, str], ...] = ()
    affordances: tuple[str, ...] = ()

    def to_attributes(self) -> tuple[Attribute, ...]:
        """The label as store attributes (source ``vlm``), affordances under ``affordance``."""
        out = [Attribute(k, v, AttributeSource.VLM) for k, v in self.attributes]
        out += [Attribute("affordance", a, AttributeSource.VLM) for a in self.affordances]
        return tuple(sorted(set(out)))


def _template(name: str) -> Template:
    text = resources.files("causalsplat.openai_compat").joinpath("prompts", name).read_text("utf-8")
    return Template(text)


def parse_label(content: str) -> EntityLabel:
    """Validate one reply; raises :class:`VLMReplyError` naming the problem."""
    try:
        data = json.loads(_strip_fences(content))
    except json.JSONDecodeError as exc:
        raise VLMReplyError(f"the reply is not JSON ({exc.msg})", reason="json") from exc
    if not isinstance(data, dict):
        raise VLMReplyError("the reply is not a JSON object", reason="schema")
    extra = sorted(set(data) - set(_KEYS))
    if extra:
        raise VLMReplyError(f"unexpected keys {extra}", reason="schema")
    category = data.get("category")
    if not isinstance(category, str) or not category.strip():
        raise VLMReplyError("'category' must be a non-empty string", reason="schema")
    attributes = []
    for key in ("color", "material", "state"):
        value = data.get(key, "")
        if not isinstance(value, str):
            raise VLMReplyError(f"{key!r} must be a string, got {value!r}", reason="schema")
        if value.strip():
            attributes.append((key, " ".join(value.lower().split())))
    affordances = data.get("affordances", [])
    if not isinstance(affordances, list) or not all(isinstance(a, str) for a in affordances):
        raise VLMReplyError("'affordances' must be a list of strings", reason="schema")
    cleaned = tuple(dict.fromkeys(" ".join(a.lower().split()) for a in affordances if a.strip()))
    return EntityLabel(" ".join(category.lower().split()), tuple(attributes), cleaned[:8])


def _strip_fences(content: str) -> str:
    text = content.strip()
    if text.startswith("```"):
        text = text.split("\n", 1)[1] if "\n" in text else ""
        text = text.rsplit("```", 1)[0]
    return text.strip()


def _checked(reply: ChatReply, max_tokens: int) -> EntityLabel:
    check_finished(reply, max_tokens)
    return parse_label(reply.content)


def _label_one(client: ChatClient, messages: list[Message]) -> EntityLabel:
    """One label: a request, and one retry that fixes what made the first reply fail."""
    budget = client.config.max_tokens
    reply = client.complete(messages, response_format=RESPONSE_FORMAT, max_tokens=budget)
    first: VLMReplyError
    try:
        return _checked(reply, budget)
    except VLMTruncatedError as exc:
        first, budget = exc, retry_budget(budget)
        note = _template("label_retry.txt").substitute(error=f"{exc}; use shorter values")
        messages = with_note(messages, note)
    except VLMReplyError as exc:
        first = exc
        retry = _template("label_retry.txt").substitute(error=str(exc))
        messages = [
            *messages,
            {"role": "assistant", "content": reply.content},
            {"role": "user", "content": retry},
        ]
    second = client.complete(messages, response_format=RESPONSE_FORMAT, max_tokens=budget)
    try:
        return _checked(second, budget)
    except VLMReplyError as exc:
        raise exc.after(first) from exc


def label_crops(
    client: ChatClient, crops: Sequence[np.ndarray], *, hints: Sequence[str | None] | None = None
) -> list[EntityLabel]:
    """One :class:`EntityLabel` per crop (module docstring). ``hints`` (optional, one per
    crop) are category guesses put in the prompt, e.g. a mask vote."""
    system = _template("label_system.txt").substitute()
    out = []
    for i, crop in enumerate(crops):
        hint = hints[i] if hints is not None else None
        text = _template("label_user.txt").substitute(hint=f" It may be a {hint}." if hint else "")
        messages: list[Message] = [
            {"role": "system", "content": system},
            {"role": "user", "content": [{"type": "text", "text": text}, image_part(crop)]},
        ]
        out.append(_label_one(client, messages))
    return out


class VLMLabeler:
    """Labels entities from their mask crops with a VLM server (see :func:`label_crops`)."""

    name = "vlm"

    def __init__(self, client: ChatClient | None = None) -> None:
        self.client = client or ChatClient()

    def label_crops(
        self, crops: Sequence[np.ndarray], *, hints: Sequence[str | None] | None = None
    ) -> list[EntityLabel]:
        return label_crops(self.client, crops, hints=hints)

    __call__ = label_crops
