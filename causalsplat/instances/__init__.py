"""3D instance assignment: HDBSCAN over mask features, an entity per Gaussian, and quality.

:func:`assign_instances` turns a feature field and its mask features into an
:class:`InstanceAssignment`; :func:`instance_quality` scores a labelling against ground
truth (mean best-match IoU, AP25/AP50). numpy / scipy (numba where it imports); no torch.
"""

from causalsplat.instances.assign import InstanceAssignment, assign_instances, cluster_masks
from causalsplat.instances.config import InstanceConfig, InstanceConfigError
from causalsplat.instances.quality import InstanceQuality, instance_quality, scene_quality

__all__ = [
    "InstanceAssignment",
    "InstanceConfig",
    "InstanceConfigError",
    "InstanceQuality",
    "assign_instances",
    "cluster_masks",
    "instance_quality",
    "scene_quality",
]
