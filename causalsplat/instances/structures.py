"""One floor, one ceiling: the clusters a scene's single structures fell into, joined.

A floor or a ceiling is one surface that no view shows whole. Each view's mask covers the
part in front of the camera, and two masks of far-apart parts share no Gaussian, so
nothing ties their features together but chains of views in between: the field often
leaves them in several clusters, and the multi-view consensus
(:mod:`causalsplat.instances.consensus`), which needs shared Gaussians, cannot join them.
The masks' labels can. A cluster's label is the one most of its labelled masks carry
(more than half of them); clusters labelled as the same single structure
(``InstanceConfig.merge_structures``, ``("floor", "ceiling")`` by default) are joined,
wherever they lie: a scanned ceiling often has holes that leave its parts metres apart.
Walls are not single structures: a room has several. A capture of several rooms gets one
floor and one ceiling; ``merge_structures=()`` keeps them apart.

>>> import numpy as np
>>> labels = cluster_labels(np.array([0, 1, 2, 3, 3, -1]),
...                         ["Floor", "floor ", "ceiling", "chair", None, "floor"], 4)
>>> labels
['floor', 'floor', 'ceiling', 'chair']
>>> structure_pairs(labels, ("floor", "ceiling")).astype(int)
array([[1, 1, 0, 0],
       [1, 1, 0, 0],
       [0, 0, 1, 0],
       [0, 0, 0, 1]])
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence

import numpy as np


def cluster_labels(
    cluster: np.ndarray, mask_labels: Sequence[str | None], k: int
) -> list[str | None]:
    """The label (stripped, lower-cased) held by more than half of each of the ``k``
    clusters' labelled masks, or ``None``; ``cluster`` (M,) and ``mask_labels`` (M,) per
    mask, -1 and ``None`` for none."""
    counts: list[Counter[str]] = [Counter() for _ in range(k)]
    for c, label in zip(cluster.tolist(), mask_labels, strict=True):
        if c >= 0 and label is not None and label.strip():
            counts[c][label.strip().lower()] += 1
    out: list[str | None] = []
    for count in counts:
        top = count.most_common(1)
        total = sum(count.values())
        out.append(top[0][0] if top and 2 * top[0][1] > total else None)
    return out


def structure_pairs(labels: Sequence[str | None], structures: Sequence[str]) -> np.ndarray:
    """(K, K) bool: clusters labelled as one single structure (module docstring), and
    the diagonal."""
    k = len(labels)
    wanted = {s.strip().lower() for s in structures}
    named = np.array([label if label in wanted else "" for label in labels], dtype=object)
    return np.eye(k, dtype=bool) | ((named[:, None] == named[None, :]) & (named != "")[:, None])
