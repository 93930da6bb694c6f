"""Progressive morphological openings of a lowest-point raster (Zhang et al. 2003; SMRF)."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from tdb.fill import fill_nearest

SMALL = 4  # cells: the windows grow one cell at a time up to this radius


def window_radii(max_window: float, cell: float, *, unit_steps_from: float = np.inf) -> Iterator[int]:
    """The openings' window radii in cells: 1 to :data:`SMALL`, then doubling, and one cell at a
    time again from ``unit_steps_from`` m on, up to ``max_window`` m.

    Each step flags what it lowers by more than the slope allows for its radius. Between two
    windows far apart a broad convex form (a mound's top, a plateau's edge over a cliff) is
    lowered by its own slope times the whole jump, and flagged; grown one cell at a time, it is
    lowered a little at each step, while a roof still goes at once, where a window first spans it.
    """
    radius = 1
    while radius * cell <= max_window:
        yield radius
        radius = radius + 1 if radius < SMALL or radius * cell >= unit_steps_from else 2 * radius


def progressive_opening(
    zmin: NDArray[np.float64],
    *,
    cell: float,
    max_window: float,
    slope: float,
    offset: float = 0.05,
    unit_steps_from: float = np.inf,
) -> NDArray[np.bool_]:
    """Object mask of a lowest-point raster by openings with growing windows
    (:func:`window_radii`).

    A cell is an object once an opening lowers it by more than
    ``offset + slope × window radius``. Applied to ``-zmin`` it finds pits instead.
    """
    surface = fill_nearest(zmin)
    objects = np.zeros(zmin.shape, bool)
    for radius in window_radii(max_window, cell, unit_steps_from=unit_steps_from):
        size = 2 * radius + 1
        # "nearest": terrain continues past the data edge, so a terrace cut by the
        # edge is not mistaken for an object narrower than the window.
        opened = ndimage.maximum_filter(
            ndimage.minimum_filter(surface, size=size, mode="nearest"), size=size, mode="nearest"
        )
        objects |= surface - opened > slope * radius * cell + offset
        surface = opened
    return objects & ~np.isnan(zmin)
