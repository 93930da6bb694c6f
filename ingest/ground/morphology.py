"""Progressive morphological openings of a lowest-point raster (Zhang et al. 2003; SMRF)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from tdb.fill import fill_nearest


def progressive_opening(
    zmin: NDArray[np.float64], *, cell: float, max_window: float, slope: float, offset: float = 0.05
) -> NDArray[np.bool_]:
    """Object mask of a lowest-point raster by openings with growing windows.

    A cell is an object once an opening lowers it by more than
    ``offset + slope × window radius``. Applied to ``-zmin`` it finds pits instead.
    """
    surface = fill_nearest(zmin)
    objects = np.zeros(zmin.shape, bool)
    radius = 1
    while radius * cell <= max_window:
        size = 2 * radius + 1
        # "nearest": terrain continues past the data edge, so a terrace cut by the
        # edge is not mistaken for an object narrower than the window.
        opened = ndimage.maximum_filter(
            ndimage.minimum_filter(surface, size=size, mode="nearest"), size=size, mode="nearest"
        )
        objects |= surface - opened > slope * radius * cell + offset
        surface = opened
        radius = radius * 2 if radius >= 4 else radius + 1
    return objects & ~np.isnan(zmin)
