"""Building a stored scene graph from a scene folder (DESIGN §9).

:func:`build_scene` reads the folder, runs the cached stages (rasterize, field, instances,
graph) and returns a :class:`BuildResult`; :class:`BuildConfig` holds every knob and reads
a JSON config file. Importing this package does not import torch.
"""

from causalsplat.build.config import BuildConfig, BuildConfigError
from causalsplat.build.errors import BuildError, CoverageError, StageError
from causalsplat.build.folder import SceneFolder, SceneFolderFormatError, read_scene_folder
from causalsplat.build.pipeline import BuildResult, StageReport, build_scene

__all__ = [
    "BuildConfig",
    "BuildConfigError",
    "BuildError",
    "BuildResult",
    "CoverageError",
    "SceneFolder",
    "SceneFolderFormatError",
    "StageError",
    "StageReport",
    "build_scene",
    "read_scene_folder",
]
