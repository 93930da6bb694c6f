"""Rasterising points: cell indices, lowest point per cell, filling holes."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from tdb.errors import InputError

MAX_CELLS = 400_000_000  # ~3 GB of float64: beyond this the extent is absurd for the cell size


@dataclass(frozen=True)
class Grid:
    """A raster frame: origin at the lower-left corner, ``shape`` = (rows, cols), rows run north."""

    x0: float
    y0: float
    cell: float
    shape: tuple[int, int]

    @classmethod
    def covering(cls, xy: NDArray[np.float64], cell: float) -> Grid:
        lo = np.floor(xy.min(axis=0) / cell) * cell
        hi = xy.max(axis=0)
        cols = int(np.floor((hi[0] - lo[0]) / cell)) + 1
        rows = int(np.floor((hi[1] - lo[1]) / cell)) + 1
        if rows * cols > MAX_CELLS:
            raise InputError(
                f"extent {hi[0] - lo[0]:.0f} × {hi[1] - lo[1]:.0f} needs {rows * cols:,} cells of {cell} m; "
                "check the units and coordinates (or tile the data)"
            )
        return cls(float(lo[0]), float(lo[1]), cell, (rows, cols))

    def index(self, xy: NDArray[np.float64]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
        """(row, col) of each point; row 0 is the southern edge."""
        col = np.clip(((xy[:, 0] - self.x0) / self.cell).astype(np.intp), 0, self.shape[1] - 1)
        row = np.clip(((xy[:, 1] - self.y0) / self.cell).astype(np.intp), 0, self.shape[0] - 1)
        return row, col

    def centres(self) -> tuple[NDArray[np.floating], NDArray[np.floating]]:
        xs = self.x0 + (np.arange(self.shape[1]) + 0.5) * self.cell
        ys = self.y0 + (np.arange(self.shape[0]) + 0.5) * self.cell
        return xs, ys

    def sample(self, raster: NDArray[np.float64], xy: NDArray[np.float64]) -> NDArray[np.float64]:
        """Bilinear interpolation of a raster (rows south to north) at points."""
        fx = np.clip((xy[:, 0] - self.x0) / self.cell - 0.5, 0, self.shape[1] - 1)
        fy = np.clip((xy[:, 1] - self.y0) / self.cell - 0.5, 0, self.shape[0] - 1)
        return ndimage.map_coordinates(raster, [fy, fx], order=1, mode="nearest")


def lowest_per_cell(grid: Grid, xyz: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """Raster of the lowest z per cell (NaN where empty) and the index of that point (-1 where empty)."""
    row, col = grid.index(xyz[:, :2])
    flat = row * grid.shape[1] + col
    order = np.lexsort((xyz[:, 2], flat))
    first = np.r_[True, flat[order][1:] != flat[order][:-1]]
    idx = np.full(grid.shape[0] * grid.shape[1], -1, np.intp)
    idx[flat[order][first]] = order[first]
    z = np.full(idx.shape, np.nan)
    z[idx >= 0] = xyz[idx[idx >= 0], 2]
    return z.reshape(grid.shape), idx.reshape(grid.shape)


def fill_nearest(raster: NDArray[np.float64]) -> NDArray[np.float64]:
    """Replace NaN cells by the value of the nearest filled cell."""
    holes = np.isnan(raster)
    if not holes.any():
        return raster
    if holes.all():
        raise InputError("raster has no data to fill from")
    _, (ri, ci) = ndimage.distance_transform_edt(holes, return_indices=True)
    return raster[ri, ci]
