"""A small OpenAI-compatible chat client, shared by the reasoner and the entity labeler.

Graph construction imports this package (for :class:`VLMLabeler`) and never the reasoner.
Nothing here needs torch; the ``openai`` package (the ``vlm`` extra) is needed only to
talk to a server, not to replay a recording.
"""

from causalsplat.openai_compat.client import (
    ENV_API_KEY,
    ENV_BASE_URL,
    ENV_MAX_TOKENS,
    ENV_MODEL,
    ChatClient,
    ChatReply,
    VLMConfig,
    check_finished,
    parse_max_tokens,
    request_key,
    retry_budget,
)
from causalsplat.openai_compat.errors import (
    ReplayMissError,
    VLMConfigError,
    VLMError,
    VLMRefusalError,
    VLMReplyError,
    VLMTimeoutError,
    VLMTransportError,
    VLMTruncatedError,
)
from causalsplat.openai_compat.images import encode_png, image_data_url, image_part
from causalsplat.openai_compat.labeler import EntityLabel, VLMLabeler, label_crops, parse_label

__all__ = [
    "ENV_API_KEY",
    "ENV_BASE_URL",
    "ENV_MAX_TOKENS",
    "ENV_MODEL",
    "ChatClient",
    "ChatReply",
    "EntityLabel",
    "ReplayMissError",
    "VLMConfig",
    "VLMConfigError",
    "VLMError",
    "VLMLabeler",
    "VLMRefusalError",
    "VLMReplyError",
    "VLMTimeoutError",
    "VLMTransportError",
    "VLMTruncatedError",
    "check_finished",
    "encode_png",
    "image_data_url",
    "image_part",
    "label_crops",
    "parse_label",
    "parse_max_tokens",
    "request_key",
    "retry_budget",
]
