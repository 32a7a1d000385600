"""Time the two feature-field trainers on the same views: numpy (CPU) against torch.

    python scripts/bench_trainers.py FOLDER[,FOLDER...] [--device cpu|cuda] [--repeats 2]

For each scene folder (``causalsplat prepare-scannet``, ``causalsplat synth``, or one
densified by ``causalsplat.bench._densify.densify_folder``) the views are prepared once,
then the default field config trains ``repeats`` times on each trainer, from the same
initial features: the wall time, the time per step and the mean loss of the last 50 steps
(the two trainers take the same steps, so their losses agree). On CUDA the first torch run
of the process includes CUDA's start; the line before the scenes times that start alone.
The figures in docs/benchmarks.md ("Training on torch") come from this script.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np
import torch

from causalsplat.build import BuildConfig
from causalsplat.build.folder import read_scene_folder
from causalsplat.field import prepare_views
from causalsplat.field.blas import single_threaded_blas
from causalsplat.field.train import train_features
from causalsplat.field.train_torch import train_features_torch
from causalsplat.field.weights import normalize_rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("folders", help="scene folders, comma-separated")
    parser.add_argument("--device", choices=("cpu", "cuda"), default="cpu")
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args()
    t0 = time.perf_counter()
    if args.device == "cuda":
        torch.zeros(1, device="cuda")
        torch.cuda.synchronize()
    print(f"{args.device} start {time.perf_counter() - t0:.2f} s", flush=True)
    config = BuildConfig().field
    on_torch = dataclasses.replace(config, trainer="torch", device=args.device)
    for path in args.folders.split(","):
        folder = read_scene_folder(Path(path))
        t0 = time.perf_counter()
        views = prepare_views(folder.gaussians, folder.cameras, folder.masks, config)
        print(f"{path}: {int(views.active.sum()):,} active Gaussians, "
              f"views prepared in {time.perf_counter() - t0:.1f} s", flush=True)  # fmt: skip
        init = normalize_rows(views.uplift)
        trainers = (("numpy", train_features, config),
                    (f"torch-{args.device}", train_features_torch, on_torch))  # fmt: skip
        for name, train, cfg in trainers:
            for rep in range(args.repeats):
                with single_threaded_blas():
                    t0 = time.perf_counter()
                    _, losses = train(views.contributors, views.masks, init, cfg)
                    if args.device == "cuda":
                        torch.cuda.synchronize()
                    dt = time.perf_counter() - t0
                print(f"  {name} run {rep + 1}: {dt:.2f} s "
                      f"({1000 * dt / max(len(losses), 1):.1f} ms/step), "
                      f"last-50 loss {np.mean(losses[-50:]):.4f}", flush=True)  # fmt: skip
        views.close()


if __name__ == "__main__":
    main()
