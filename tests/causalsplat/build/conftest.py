"""Synthetic tiny scene folders, generated once per test session."""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture(scope="session")
def tiny_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from causalsplat.synth import synth_scene

    out = tmp_path_factory.mktemp("build-synth") / "tiny0"
    synth_scene("tiny", 0, out)
    return out


@pytest.fixture(scope="session")
def batch_folders(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    """Three tiny synthetic scene folders (ids synth-tiny-0 .. 2)."""
    from causalsplat.synth import synth_scene

    root = tmp_path_factory.mktemp("batch")
    folders = [root / f"tiny{seed}" for seed in range(3)]
    for seed, folder in enumerate(folders):
        synth_scene("tiny", seed, folder)
    return folders
