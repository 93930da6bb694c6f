"""Low outliers: points far below every plausible ground around them.

Multipath and bird-strike returns can lie tens of metres below the terrain; a
filter that grows ground from the lowest points would anchor on them.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree


def low_outliers(
    xyz: NDArray[np.float64], *, k: int = 12, rank: int = 3, drop: float = 3.0, passes: int = 2
) -> NDArray[np.bool_]:
    """Mask of points lower than the ``rank``-th lowest of their ``k`` plan neighbours by > ``drop`` m.

    Taking the ``rank``-th lowest neighbour rather than the lowest lets small
    clusters of outliers (up to ``rank`` - 1 together) be found; a second pass
    catches what the first one's outliers hid.
    """
    xyz = np.asarray(xyz, float)
    out = np.zeros(len(xyz), bool)
    for _ in range(passes):
        keep = np.flatnonzero(~out)
        if len(keep) <= k:
            break
        tree = cKDTree(xyz[keep, :2])
        _, nb = tree.query(xyz[keep, :2], k=k + 1)
        nz = np.sort(xyz[keep[nb[:, 1:]], 2], axis=1)
        floor = nz[:, min(rank, k) - 1]
        new = xyz[keep, 2] < floor - drop
        if not new.any():
            break
        out[keep[new]] = True
    return out
