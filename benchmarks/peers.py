"""Peer ground filters from PyPI, wrapped to the same call: xyz (N, 3) -> ground mask."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def smrf(xyz: NDArray[np.float64]) -> NDArray[np.bool_]:
    """pysmrf with the parameters PDAL uses by default (as the issue specifies)."""
    import pysmrf

    result = pysmrf.classify(
        xyz[:, 0],
        xyz[:, 1],
        xyz[:, 2],
        cellsize=1,
        windows=18,
        slope_threshold=0.15,
        elevation_threshold=0.5,
        elevation_scaler=1.25,
    )
    return np.asarray(result.is_ground, bool)


def csf(xyz: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Cloth Simulation Filter with its default parameters."""
    import CSF

    f = CSF.CSF()
    f.setPointCloud(np.ascontiguousarray(xyz))
    ground, other = CSF.VecInt(), CSF.VecInt()
    f.do_filtering(ground, other, exportCloth=False)
    mask = np.zeros(len(xyz), bool)
    mask[np.asarray(ground, dtype=np.intp)] = True
    return mask
