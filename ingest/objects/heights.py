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

    def plane_departure(self, xy: NDArray[np.float64], cells: NDArray[np.bool_]) -> NDArray[np.float64]:
        """At the ``cells`` asked for, the root-mean-square departure (m) of the top points of
        the cell and its eight neighbours from their least-squares plane, at the points' true
        positions; NaN elsewhere and where fewer than four points.

        The second derivative of a raster reads a point's place in its cell as relief: a cell's
        highest point lies anywhere in it, so on a roof of slope s the raster is off the plane
        by up to s × half a cell and a steep roof looks as rough as a crown. The plane through
        the points themselves is exact on any roof plane, flat or steep; a ridge departs from
        it along the ridge only, a crown everywhere.
        """
        rows, cols = self.grid.shape
        out = np.full((rows, cols), np.nan)
        at = np.flatnonzero(cells.ravel())
        if len(at) == 0:
            return out
        r, c = np.divmod(at, cols)
        xs, ys = self.grid.centres()
        index, height = self.index.ravel(), self.height.ravel()
        base = float(np.nanmedian(height[at]))  # heights about it: the sums stay well conditioned
        moments = np.zeros((10, len(at)))  # n, Σu, Σv, Σz, Σuu, Σuv, Σvv, Σuz, Σvz, Σzz
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                rr, cc = r + dr, c + dc
                inside = (rr >= 0) & (rr < rows) & (cc >= 0) & (cc < cols)
                flat = np.where(inside, rr * cols + cc, 0)
                k = np.where(inside, index[flat], -1)
                w = k >= 0
                kk = np.maximum(k, 0)
                u = np.where(w, xy[kk, 0] - xs[c], 0.0)  # relative to the asking cell's centre
                v = np.where(w, xy[kk, 1] - ys[r], 0.0)
                z = np.where(w, height[flat] - base, 0.0)
                moments += np.stack([w, u, v, z, u * u, u * v, v * v, u * z, v * z, z * z])
        n, su, sv, sz, suu, suv, svv, suz, svz, szz = moments
        m = np.maximum(n, 1)
        cuu, cuv, cvv = suu - su * su / m, suv - su * sv / m, svv - sv * sv / m
        cuz, cvz, czz = suz - su * sz / m, svz - sv * sz / m, szz - sz * sz / m
        det = cuu * cvv - cuv * cuv
        ok = (n >= 4) & (det > 1e-6 * self.grid.cell**4)
        safe = np.where(ok, det, 1.0)
        gx = (cvv * cuz - cuv * cvz) / safe
        gy = (cuu * cvz - cuv * cuz) / safe
        rss = np.maximum(czz - gx * cuz - gy * cvz, 0.0)
        out.ravel()[at] = np.where(ok, np.sqrt(rss / m), np.nan)
        return out
