"""Heights above the ground model, and the highest of them per cell."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ingest.ground.grids import Grid
from tdb.raster import Raster


def above_ground(xyz: NDArray[np.float64], dtm: Raster) -> NDArray[np.float64]:
    """Height (m) of each point over the dense ground model; NaN where the model has no data."""
    return xyz[:, 2] - dtm.sample(xyz[:, 0], xyz[:, 1])


@dataclass(frozen=True)
class TopRaster:
    """The highest point per cell: its height above ground and its index (rows south to north).

    ``height`` is NaN and ``index`` −1 where a cell holds no point with a known height.
    """

    grid: Grid
    height: NDArray[np.float64]
    index: NDArray[np.intp]

    @classmethod
    def of(cls, grid: Grid, xy: NDArray[np.float64], h: NDArray[np.float64]) -> TopRaster:
        known = np.flatnonzero(np.isfinite(h))
        row, col = grid.index(xy[known])
        flat = row * grid.shape[1] + col
        size = grid.shape[0] * grid.shape[1]
        # Two passes over the points and no sort: the highest per cell, then which point it is
        # (of equal heights, the last in the input).
        top = np.full(size, -np.inf)
        np.maximum.at(top, flat, h[known])
        index = np.full(size, -1, np.intp)
        at_top = h[known] == top[flat]
        index[flat[at_top]] = known[at_top]
        height = np.where(index >= 0, top, np.nan)
        return cls(grid, height.reshape(grid.shape), index.reshape(grid.shape))

    def cells_of(self, xy: NDArray[np.float64]) -> NDArray[np.intp]:
        """Flat cell index of each point."""
        row, col = self.grid.index(xy)
        return row * self.grid.shape[1] + col
