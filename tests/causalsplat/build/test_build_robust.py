"""Builds that must not fail: densified scenes (near-duplicate Gaussians); and a stage that
fails anyway is one typed line naming the stage, in the API and on the command line."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from causalsplat import open_store
from causalsplat.bench._densify import densify_folder
from causalsplat.build import BuildConfig, BuildError, StageError, build_scene, pipeline
from causalsplat.build.errors import MAX_REASON, describe_error
from causalsplat.cli import cli
from causalsplat.errors import InputFormatError
from causalsplat.field import FieldConfig
from causalsplat.io import read_gaussian_ply

#: The cheapest build that still gives entities: few views, few training steps.
QUICK = BuildConfig(field=FieldConfig(iterations=10), max_views=6)


@pytest.mark.parametrize("copies", [4, 16])
def test_densified_scenes_build_and_store(tiny_folder: Path, tmp_path: Path, copies: int) -> None:
    """Every Gaussian copied 4 or 16 times (two exact duplicates each, the rest 5 % of its
    size apart): the copies form nearly closed clusters of the surface graph, which made
    the instances stage raise 'Factor is exactly singular' at 16 copies."""
    folder = densify_folder(tiny_folder, tmp_path / f"dense{copies}", copies, jitter=0.05)
    n = read_gaussian_ply(tiny_folder / "point_cloud.ply").scene.n
    with open_store(f"sqlite:///{tmp_path / 'dense.db'}") as store:
        scene = store.build(folder, scene_id="dense", config=QUICK, cache_dir=False)
        report = scene.build_report
        assert report is not None and report.n_gaussians == copies * n
        assert len(store.scene("dense").graph.entities) >= 3
        stored = store.scene("dense").gaussian_labels()
    assert stored is not None and stored.shape == (copies * n,)
    assert (stored >= 0).mean() > 0.5
    assert report.quality is not None and report.quality.mean_best_iou > 0.3


def _fail_in_instances(monkeypatch: pytest.MonkeyPatch, exc: Exception) -> None:
    def broken(*_: object, **__: object) -> None:
        raise exc

    monkeypatch.setattr(pipeline, "assign_instances", broken)


def test_an_unforeseen_stage_error_is_one_typed_line(
    tiny_folder: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    cause = RuntimeError("Factor is exactly singular\n  (from SuperLU, more detail here)")
    _fail_in_instances(monkeypatch, cause)
    with pytest.raises(StageError) as info:
        build_scene(tiny_folder, config=QUICK, cache_dir=False)
    error = info.value
    assert isinstance(error, BuildError) and error.stage == "instances"
    assert str(error) == (
        f"{tiny_folder}: instances stage failed: RuntimeError: Factor is exactly singular"
    )
    assert error.__cause__ is cause


def test_errors_that_already_say_what_went_wrong_pass_unchanged(
    tiny_folder: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    typed = InputFormatError("masks/view_000.npz: 'masks' is not boolean")
    _fail_in_instances(monkeypatch, typed)
    with pytest.raises(InputFormatError) as info:
        build_scene(tiny_folder, config=QUICK, cache_dir=False)
    assert info.value is typed


def test_the_load_stage_is_named_too(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def broken(*_: object, **__: object) -> None:
        raise ZeroDivisionError("float division by zero")

    monkeypatch.setattr(pipeline, "read_scene_folder", broken)
    with pytest.raises(StageError, match=r": load stage failed: ZeroDivisionError: float div"):
        build_scene(tmp_path, cache_dir=False)


def test_describe_error() -> None:
    assert describe_error(ValueError("bad value\nsecond line")) == "ValueError: bad value"
    assert describe_error(MemoryError()) == "MemoryError"
    assert describe_error(KeyError("x")) == "KeyError: 'x'"
    disk = OSError(28, "No space left on device", "/cache/field/ab.npz")
    assert describe_error(disk) == "OSError: No space left on device: /cache/field/ab.npz"
    long = describe_error(RuntimeError("x" * 1000))
    assert len(long) == MAX_REASON and long.endswith("...")


def test_cli_prints_a_stage_failure_as_one_line(
    tiny_folder: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _fail_in_instances(monkeypatch, RuntimeError("Factor is exactly singular"))
    config = tmp_path / "quick.json"
    config.write_text(json.dumps({"max_views": 6, "field": {"iterations": 10}}))
    db = tmp_path / "cli.db"
    args = ["build", str(tiny_folder), "--config", str(config), "--no-cache", "--no-progress",
            "--db", f"sqlite:///{db}"]  # fmt: skip
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 1, result.output
    assert result.stdout == ""
    lines = result.stderr.strip().splitlines()
    assert lines == [
        f"causalsplat: error: {tiny_folder}: instances stage failed: "
        "RuntimeError: Factor is exactly singular"
    ]
    assert "Traceback" not in result.output
    if db.exists():  # nothing half-written
        with open_store(f"sqlite:///{db}") as store:
            assert store.scenes() == []
