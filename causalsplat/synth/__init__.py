"""Procedural synthetic benchmark scenes (DESIGN §11): rooms from a seed, with GT everything.

A room is a set of axis-aligned boxes (floor, walls, furniture, small objects stacked in
support chains, one object resting on two supporters), Gaussians sampled on their
surfaces, cameras inside the room, rendered RGB, exact instance masks from the id render,
SAM-like noisy masks (:mod:`causalsplat.masks.noise`), and queries of all four reasoning
levels answered from the generator's own ground truth. Sizes ``tiny`` (CI), ``small``
(demo), ``medium`` (benchmarks); the same seed always writes the same bytes.

    from causalsplat.synth import SynthConfig, generate_scene, write_synth_scene
    scene = generate_scene(SynthConfig.preset("tiny", seed=0))
    write_synth_scene(scene, "scenes/tiny0")
"""

from causalsplat.synth.config import SIZES, InvalidSynthConfigError, SynthConfig
from causalsplat.synth.folder import SceneFolderError
from causalsplat.synth.generate import SynthScene, generate_scene
from causalsplat.synth.write import SceneSummary, synth_scene, write_synth_scene

__all__ = [
    "SIZES",
    "InvalidSynthConfigError",
    "SceneFolderError",
    "SceneSummary",
    "SynthConfig",
    "SynthScene",
    "generate_scene",
    "synth_scene",
    "write_synth_scene",
]
