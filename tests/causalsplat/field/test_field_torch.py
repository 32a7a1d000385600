"""The torch trainer: autograd and torch.optim.Adam, held to the numpy trainer step by step.

CI has no GPU: these run the torch code on ``device="cpu"``, the same code a CUDA build
runs. The build-level test asserts where a build's gradients and clusters come from.
"""

from __future__ import annotations

import dataclasses
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch")
hdbscan = pytest.importorskip("hdbscan")

from causalsplat.build import BuildConfig, build_scene  # noqa: E402
from causalsplat.build.folder import read_scene_folder  # noqa: E402
from causalsplat.errors import MissingDependencyError  # noqa: E402
from causalsplat.field import FieldConfig, prepare_views  # noqa: E402
from causalsplat.field.device import resolve_trainer  # noqa: E402
from causalsplat.field.train import (  # noqa: E402
    _view_terms,
    contrastive_loss_and_grad,
    mask_overlap,
    train_features,
)
from causalsplat.field.train_torch import (  # noqa: E402
    contrastive_loss,
    train_features_torch,
)
from causalsplat.field.weights import normalize_rows  # noqa: E402
from causalsplat.synth import synth_scene  # noqa: E402

CPU = FieldConfig(device="cpu", trainer="torch")


@pytest.fixture(scope="module")
def tiny(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("torch") / "tiny"
    synth_scene("tiny", 0, folder)
    return folder


@pytest.fixture(scope="module")
def views(tiny: Path):  # type: ignore[no-untyped-def]
    folder = read_scene_folder(tiny)
    v = prepare_views(folder.gaussians, folder.cameras, folder.masks, CPU)
    yield v
    v.close()


def test_loss_and_gradient_equal_the_numpy_trainers(views) -> None:  # type: ignore[no-untyped-def]
    vm = next(m for m in views.masks if m.n_masks > 1)
    terms = _view_terms(vm, None, mask_overlap(vm, CPU.nested_share))
    rng = np.random.default_rng(3)
    f = rng.standard_normal((terms.pixels.shape[0], CPU.feature_dim)).astype(np.float64)
    f[0] = 0.0  # a pixel nothing is drawn at
    loss, grad = contrastive_loss_and_grad(f, terms, CPU, np.random.default_rng(9))
    draw = np.random.default_rng(9).random((f.shape[0], terms.weights.shape[0]), np.float32)
    ft = torch.tensor(f, requires_grad=True)
    ref = contrastive_loss(
        ft,
        torch.from_numpy(terms.weights).double(),
        torch.from_numpy(terms.negative),
        torch.from_numpy(terms.n_pos).double(),
        torch.from_numpy(draw),
        CPU,
    )
    ref.backward()
    assert float(ref.detach()) == pytest.approx(loss, rel=1e-8)  # weight sums: float32 there
    np.testing.assert_allclose(ft.grad.numpy(), grad, rtol=1e-4, atol=1e-10)
    assert np.abs(grad).max() > 1e-4


DEVICES = ["cpu", pytest.param("cuda", marks=pytest.mark.skipif(
    not torch.cuda.is_available(), reason="no CUDA device"))]  # fmt: skip


@pytest.mark.parametrize("device", DEVICES)
def test_the_two_trainers_take_the_same_steps(views, device: str) -> None:  # type: ignore[no-untyped-def]
    config = dataclasses.replace(CPU, iterations=60, device=device)
    init = normalize_rows(views.uplift)
    ours, ours_loss = train_features_torch(views.contributors, views.masks, init, config)
    ref, ref_loss = train_features(views.contributors, views.masks, init, config)
    assert len(ours_loss) == len(ref_loss) == 60
    np.testing.assert_allclose(ours_loss, ref_loss, rtol=2e-4, atol=1e-5)
    assert ours_loss[-1] < ours_loss[0]
    np.testing.assert_allclose(ours, ref, atol=5e-4)
    assert ours.dtype == np.float64 and ours.shape == init.shape


def test_a_build_takes_its_gradients_from_autograd_and_its_clusters_from_hdbscan(
    tiny: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    backward_calls, fits = [], []
    real_backward, real_hdbscan = torch.Tensor.backward, hdbscan.HDBSCAN

    def backward(self, *a, **kw):  # type: ignore[no-untyped-def]
        backward_calls.append(1)
        return real_backward(self, *a, **kw)

    def model(**kw):  # type: ignore[no-untyped-def]
        fits.append(kw)
        return real_hdbscan(**kw)

    monkeypatch.setattr(torch.Tensor, "backward", backward)
    monkeypatch.setattr(hdbscan, "HDBSCAN", model)
    config = BuildConfig(field=CPU)
    built = build_scene(tiny, config=config, cache_dir=False)
    assert len(backward_calls) == CPU.iterations
    assert fits and built.graph.entities
    monkeypatch.undo()
    reference = build_scene(tiny, config=BuildConfig(), cache_dir=False)
    np.testing.assert_array_equal(built.gaussian_labels, reference.gaussian_labels)
    # the trainer is a speed option: both builds share their cache keys and config hash
    assert config.result_json() == BuildConfig().result_json()


def test_devices_this_machine_lacks_are_refused_in_one_line(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from causalsplat.field import device

    monkeypatch.setattr(device, "cuda_available", lambda: False)
    assert resolve_trainer(FieldConfig()) == "numpy"
    assert resolve_trainer(FieldConfig(device="cpu")) == "numpy"
    assert resolve_trainer(FieldConfig(trainer="torch")) == "torch"
    with pytest.raises(MissingDependencyError, match="torch sees no CUDA device"):
        resolve_trainer(FieldConfig(device="cuda"))
    with pytest.raises(MissingDependencyError, match="trainer='numpy' runs on the CPU only"):
        resolve_trainer(FieldConfig(device="cuda", trainer="numpy"))
    monkeypatch.setattr(device, "cuda_available", lambda: True)
    assert resolve_trainer(FieldConfig(), device.CUDA_MIN_GAUSSIANS) == "torch"
    assert resolve_trainer(FieldConfig(), device.CUDA_MIN_GAUSSIANS - 1) == "numpy"
    assert resolve_trainer(FieldConfig()) == "numpy"
    assert resolve_trainer(FieldConfig(device="cpu"), 10**7) == "numpy"
    assert resolve_trainer(FieldConfig(device="cuda"), 10) == "torch"


def test_bad_device_names_the_allowed_ones() -> None:
    from causalsplat.field import FieldConfigError

    with pytest.raises(FieldConfigError, match="device"):
        FieldConfig(device="gpu")  # type: ignore[arg-type]


def test_a_default_build_of_a_small_scene_never_imports_torch(tiny: Path, tmp_path: Path) -> None:
    code = (
        "import sys\n"
        "from causalsplat.build import build_scene\n"
        f"build_scene({str(tiny)!r}, cache_dir=False)\n"
        "print('torch' in sys.modules, 'hdbscan' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "True"]


def test_cli_device_cuda_without_one_fails_before_any_work(tiny: Path, tmp_path: Path) -> None:
    if torch.cuda.is_available():
        pytest.skip("this machine has a CUDA device")
    db = tmp_path / "scenes.db"
    proc = subprocess.run(
        [sys.executable, "-m", "causalsplat", "build", str(tiny), "--device", "cuda",
         "--no-cache", "--db", str(db)],
        capture_output=True, text=True,
    )  # fmt: skip
    assert proc.returncode == 1
    assert proc.stderr.strip().splitlines() == [
        "causalsplat: error: FieldConfig.device='cuda' but torch sees no CUDA device here "
        "(use device='auto' to train on the CPU instead)"
    ]
    assert "rasterize" not in proc.stderr and not db.exists()
