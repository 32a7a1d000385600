"""CausalSplat: reasoning over 3D Gaussian Splatting scenes through a persisted scene graph.

``import causalsplat`` stays light (no torch): the perception modules import torch
themselves when they are used.
"""

__version__ = "0.1.0"
