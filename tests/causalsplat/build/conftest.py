"""A synthetic tiny scene folder, generated once per test session."""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture(scope="session")
def tiny_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from causalsplat.synth import synth_scene

    out = tmp_path_factory.mktemp("build-synth") / "tiny0"
    synth_scene("tiny", 0, out)
    return out
