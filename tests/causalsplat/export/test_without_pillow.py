"""Without the build extra (no pillow), the figure and the answer masks say what to install,
and a scene stored from objects is refused as not built before pillow is needed."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from causalsplat import MissingDependencyError
from causalsplat.export import ExportError, draw_scene_graph, export_answer_masks
from causalsplat.objects import objects_to_scene_graph, parse_objects
from graph_store import SceneGraph
from tests.causalsplat.test_objects import KITCHEN


@pytest.fixture
def no_pillow(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "PIL", None)  # `import PIL...` raises ImportError


@pytest.fixture
def kitchen() -> SceneGraph:
    return objects_to_scene_graph(parse_objects(KITCHEN))


@pytest.mark.usefixtures("no_pillow")
def test_the_figure_names_the_build_extra(kitchen: SceneGraph, tmp_path: Path) -> None:
    with pytest.raises(MissingDependencyError, match=r"pip install 'causalsplat\[build\]'"):
        draw_scene_graph(kitchen, tmp_path / "kitchen.png")
    assert not (tmp_path / "kitchen.png").exists()


@pytest.mark.usefixtures("no_pillow")
def test_masks_of_a_scene_from_objects_are_refused_first(
    kitchen: SceneGraph, tmp_path: Path
) -> None:
    with pytest.raises(ExportError, match="only built scenes have Gaussians"):
        export_answer_masks(kitchen, None, [4], tmp_path / "masks")


@pytest.mark.usefixtures("no_pillow")
def test_masks_name_the_build_extra(kitchen: SceneGraph, tmp_path: Path) -> None:
    with pytest.raises(MissingDependencyError, match=r"pip install 'causalsplat\[build\]'"):
        export_answer_masks(kitchen, None, [4], tmp_path / "masks", source=tmp_path)
