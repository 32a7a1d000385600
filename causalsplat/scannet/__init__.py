"""The ScanNet adapter: turns ``../shared/data/scannet_scene0000_00`` into a scene folder.

One Gaussian per mesh vertex, cameras along a generated walk-through plus the real posed
frames, GT instance masks from the id render, SAM-like noisy masks labelled with the
ScanNet categories, GT objects and the Sr3D / Nr3D / ScanRefer queries.
"""

from causalsplat.scannet.source import ScanNetFormatError, ScanNetSource, load_scannet

__all__ = ["ScanNetFormatError", "ScanNetSource", "load_scannet"]
