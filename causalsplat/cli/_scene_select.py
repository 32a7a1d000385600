"""Choosing scenes on the command line: ``--scene ID``, ``--scenes GLOB``, ``--all-scenes``.

Commands that answer per scene (``query``, ``ask``) take exactly one of the three; the
selection is resolved against the store by :meth:`causalsplat.api.Store.scene_ids`, so a
glob that matches nothing is one error line and a non-zero exit status.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeVar

import click

from causalsplat.cli._app import fail

F = TypeVar("F", bound=Callable[..., Any])


@dataclass(frozen=True, slots=True)
class SceneChoice:
    """What the options asked for: one scene, or many (``pattern`` ``None``: all)."""

    scene_id: str | None
    pattern: str | None
    all_scenes: bool

    @property
    def many(self) -> bool:
        return self.scene_id is None

    @property
    def selection(self) -> str | None:
        """The argument of :meth:`Store.scene_ids` / ``query_all`` / ``ask_all``."""
        return None if self.all_scenes else self.pattern


def scene_choice(scene_id: str | None, pattern: str | None, all_scenes: bool) -> SceneChoice:
    """The choice the three options make; exits with one error line unless exactly one of
    them is given."""
    given = [
        name
        for name, on in (
            ("--scene", scene_id is not None),
            ("--scenes", pattern is not None),
            ("--all-scenes", all_scenes),
        )
        if on
    ]
    if len(given) > 1:
        fail(f"{' and '.join(given)} are mutually exclusive: give one")
    if not given:
        fail("give --scene ID, --scenes GLOB or --all-scenes")
    if pattern is not None and not pattern.strip():
        fail("--scenes needs a non-empty glob, e.g. 'scene00*'")
    return SceneChoice(scene_id, pattern, all_scenes)


def scene_options(func: F) -> F:
    """``--scene ID``, ``--scenes GLOB`` and ``--all-scenes`` (exactly one is required)."""
    options = [
        click.option("--scene", "scene_id", help="Id of the stored scene."),
        click.option(
            "--scenes",
            "scenes_glob",
            metavar="GLOB",
            help="Every stored scene whose id matches the glob (e.g. 'scene00*'), one answer"
            " per scene.",
        ),
        click.option(
            "--all-scenes", is_flag=True, help="Every stored scene, one answer per scene."
        ),
    ]
    for option in reversed(options):
        func = option(func)
    return func
