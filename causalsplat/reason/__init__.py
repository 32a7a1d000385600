"""The reasoner (DESIGN §8): instructions to structured programs to answers.

Three stages, as in the method: instruction parsing (what is asked; intrinsic queries skip
topology), topological reasoning (anchors and relations, as program steps) and the
decision (target entity ids and an explanation). Two backends:

* :class:`OfflineReasoner` (``"offline"``): deterministic rules with the shipped WordNet
  lexicon, optionally sentence embeddings (the ``embed`` extra); no network, no torch;
* :class:`VLMReasoner` (``"vlm"``): any OpenAI-compatible chat-completions server writes
  the program; replies are validated, retried once, and fall back to the offline reasoner.

>>> from causalsplat import open_store
>>> scene = open_store("sqlite:///scenes.db").scene("kitchen")          # doctest: +SKIP
>>> answer = scene.ask("if the table is removed, what falls?")          # doctest: +SKIP
>>> answer.entity_ids, answer.reasoner                                   # doctest: +SKIP
((6, 7), 'offline')
"""

from causalsplat.reason.answer import Answer, entity_documents, make_answer
from causalsplat.reason.context import SceneContext
from causalsplat.reason.errors import (
    InstructionError,
    QueriesFileError,
    ReasonError,
    UnknownReasonerError,
    UnlabelledSceneError,
)
from causalsplat.reason.reasoner import REASONERS, Reasoner, make_reasoner

__all__ = [
    "REASONERS",
    "Answer",
    "InstructionError",
    "OfflineReasoner",
    "QueriesFileError",
    "ReasonError",
    "Reasoner",
    "SceneContext",
    "UnknownReasonerError",
    "UnlabelledSceneError",
    "VLMReasoner",
    "entity_documents",
    "make_answer",
    "make_reasoner",
]


def __getattr__(name: str) -> object:
    if name == "OfflineReasoner":
        from causalsplat.reason.offline import OfflineReasoner

        return OfflineReasoner
    if name == "VLMReasoner":
        from causalsplat.reason.vlm import VLMReasoner

        return VLMReasoner
    raise AttributeError(f"module 'causalsplat.reason' has no attribute {name!r}")
