"""CausalSplat: reasoning over 3D Gaussian Splatting scenes through a persisted scene graph.

``import causalsplat`` stays light (no torch): the perception modules import torch
themselves when they are used.

>>> from causalsplat import open_store
>>> store = open_store("sqlite:///scenes.db")       # doctest: +SKIP
>>> scene = store.scene("scene0000_00")             # doctest: +SKIP
"""

from causalsplat.api import Scene, Store, open_store
from causalsplat.errors import CausalSplatError, InputFormatError, MissingDependencyError

__version__ = "0.1.0"

__all__ = [
    "CausalSplatError",
    "InputFormatError",
    "MissingDependencyError",
    "Scene",
    "Store",
    "__version__",
    "open_store",
]
