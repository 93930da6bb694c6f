"""Tile sub-grids of the dense ground model at each pyramid level.

Tiles of side L are aligned to whole multiples of L in the CRS, so tile keys
(the lower-left corner, in whole metres) match exactly between surveys. Each
tile is sampled on an n × n sub-grid of spacing L / (n − 1); neighbouring tiles
share their edge nodes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from tdb.raster import Raster

LEVELS = (2, 4, 8, 16)


def tile_key(i: NDArray[np.integer], j: NDArray[np.integer]) -> NDArray[np.int64]:
    """One int64 per integer pair (tile or node keys, negative ones too), for set operations."""
    return np.asarray(i, np.int64) * (1 << 32) + (np.asarray(j, np.int64) & 0xFFFFFFFF)


class TileIndex:
    """Position of tiles by their integer indices (i, j): sorted once, looked up many times."""

    def __init__(self, i: NDArray[np.integer], j: NDArray[np.integer]) -> None:
        key = tile_key(i, j)
        self._order = np.argsort(key)
        self._sorted = key[self._order]

    def find(self, i: NDArray[np.integer], j: NDArray[np.integer]) -> NDArray[np.intp]:
        """Index of the tile (i, j) among those indexed; −1 where there is none."""
        want = tile_key(i, j)
        out = np.full(len(want), -1, np.intp)
        if len(self._sorted) == 0:
            return out
        pos = np.minimum(np.searchsorted(self._sorted, want), len(self._sorted) - 1)
        hit = self._sorted[pos] == want
        out[hit] = self._order[pos[hit]]
        return out


@dataclass(frozen=True)
class NodeGrid:
    """Heights at nodes x = ix0·s + i·s, y = iy0·s + j·s (rows south to north); NaN = no data."""

    z: NDArray[np.float64]
    ix0: int
    iy0: int
    spacing: float

    def tiles(self, n: int) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]]:
        """(T, n*n) sub-grids and the tile-index (i, j) of each tile's lower-left node."""
        step = n - 1
        win = np.lib.stride_tricks.sliding_window_view(self.z, (n, n))[::step, ::step]
        rows, cols = win.shape[:2]
        jj, ii = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
        return (
            win.reshape(rows * cols, n * n),
            (self.ix0 // step + ii.ravel()).astype(np.int64),
            (self.iy0 // step + jj.ravel()).astype(np.int64),
        )


def node_grid(dtm: Raster, level: int, *, n: int = 5) -> NodeGrid:
    """Sample the dense model on the node lattice of ``level`` (m) covering its data.

    Coarser lattices are sampled from the model smoothed over the node spacing
    (NaN-aware), so that a 16 m tile sees the form of the terrain, not its noise.
    """
    s = level / (n - 1)
    x0, y0, x1, y1 = dtm.bounds
    half = dtm.cell / 2  # the data lie on the posts, half a cell inside the raster's edges
    x0, y0, x1, y1 = x0 + half, y0 + half, x1 - half, y1 - half
    ix0 = int(np.floor(x0 / level + 1e-9)) * (n - 1)
    iy0 = int(np.floor(y0 / level + 1e-9)) * (n - 1)
    ix1 = int(np.ceil(x1 / level - 1e-9)) * (n - 1)
    iy1 = int(np.ceil(y1 / level - 1e-9)) * (n - 1)
    xs = np.arange(ix0, ix1 + 1) * s
    ys = np.arange(iy0, iy1 + 1) * s
    source = _smoothed(dtm, sigma=0.5 * s / dtm.cell) if s > dtm.cell * 1.01 else dtm
    gx, gy = np.meshgrid(xs, ys)
    z = source.sample(gx.ravel(), gy.ravel()).reshape(gx.shape)
    return NodeGrid(z, ix0, iy0, s)


def _smoothed(dtm: Raster, *, sigma: float) -> Raster:
    data = dtm.data
    valid = ~np.isnan(data)
    num = ndimage.gaussian_filter(np.where(valid, data, 0.0), sigma, mode="nearest")
    den = ndimage.gaussian_filter(valid.astype(float), sigma, mode="nearest")
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(valid, num / den, np.nan)
    return Raster(out, dtm.x0, dtm.y1, dtm.cell, dtm.crs)
