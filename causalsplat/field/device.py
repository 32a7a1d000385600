"""Which trainer and device a build's feature field uses (imports torch only when it must).

``trainer="auto"`` trains on torch on a CUDA device when the scene has at least
:data:`CUDA_MIN_GAUSSIANS` active Gaussians, else on the numpy trainer. Measured on an H200
machine (docs/benchmarks.md, "Training on torch"): a step of the numpy trainer costs about
7 ms at 81k Gaussians and 30 ms at 651k, one on CUDA 8 and 13 ms, and CUDA's start in a
build process about 4.6 s, so the GPU pays for itself from about 600k Gaussians. It looks
for an NVIDIA GPU before it imports torch: a machine without one never pays torch's import.
"""

from __future__ import annotations

import glob
import importlib.util
from typing import Literal

from causalsplat.errors import MissingDependencyError
from causalsplat.field.config import FieldConfig

#: Active Gaussians from which ``trainer="auto"`` trains on a CUDA device (module docstring).
CUDA_MIN_GAUSSIANS = 600_000


def _nvidia_gpu_present() -> bool:
    """An NVIDIA device node or driver entry exists (cheap; no CUDA call)."""
    return bool(glob.glob("/dev/nvidia[0-9]*") or glob.glob("/proc/driver/nvidia/gpus/*"))


def cuda_available() -> bool:
    """torch is installed and sees a CUDA device (imports torch only on a machine with a GPU)."""
    if importlib.util.find_spec("torch") is None or not _nvidia_gpu_present():
        return False
    import torch

    return bool(torch.cuda.is_available())


def resolve_trainer(
    config: FieldConfig, n_gaussians: int | None = None
) -> Literal["numpy", "torch"]:
    """The trainer ``config`` selects for a scene of ``n_gaussians`` active Gaussians
    (``None``: not known yet, numpy unless asked otherwise); raises when the config names
    what this machine lacks."""
    wants_torch = config.trainer == "torch" or config.device == "cuda"
    if config.trainer == "numpy" and config.device == "cuda":
        raise MissingDependencyError(
            "FieldConfig: trainer='numpy' runs on the CPU only; use trainer='torch' or 'auto' "
            "with device='cuda'"
        )
    if wants_torch and importlib.util.find_spec("torch") is None:
        raise MissingDependencyError(
            "the torch trainer needs torch: pip install 'causalsplat[field]'"
        )
    if config.device == "cuda" and not cuda_available():
        raise MissingDependencyError(
            "FieldConfig.device='cuda' but torch sees no CUDA device here "
            "(use device='auto' to train on the CPU instead)"
        )
    if wants_torch:
        return "torch"
    large = n_gaussians is not None and n_gaussians >= CUDA_MIN_GAUSSIANS
    if config.trainer == "auto" and config.device == "auto" and large and cuda_available():
        return "torch"
    return "numpy"
