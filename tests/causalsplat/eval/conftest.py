"""The hand-made room of the reasoner tests, for the evaluation tests."""

from tests.causalsplat.reason.conftest import room, room_graph

__all__ = ["room", "room_graph"]
