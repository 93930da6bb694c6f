"""The stored model's grid: pyramid levels, the tile sub-grid, tile keys and the node lattice.

Tiles of side L (a level, in metres) are aligned to whole multiples of L in the CRS, so tile
keys (the lower-left corner, in whole metres) match exactly between surveys. Each tile is
sampled on an ``SUBGRID`` × ``SUBGRID`` sub-grid of spacing L / (SUBGRID − 1); neighbouring
tiles share their edge nodes, so all nodes of one level form one lattice. A kept point carries
a mask of the levels that keep it, one bit per level (:func:`level_bit`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tdb.errors import InputError
from tdb.raster import MAX_CELLS

LEVELS: tuple[int, ...] = (2, 4, 8, 16)
"""Tile sides of the resolution pyramid, in metres, finest first."""

SUBGRID = 5
"""Nodes per tile side."""


def level_bit(level: int) -> int:
    """The bit of ``level`` in a kept point's level mask (2 m: bit 0 … 16 m: bit 3)."""
    return 1 << LEVELS.index(level)


def node_spacing(level: int, *, n: int = SUBGRID) -> float:
    """Distance (m) between neighbouring nodes of a level's lattice."""
    return level / (n - 1)


def corner_nodes(n: int = SUBGRID) -> NDArray[np.intp]:
    """Flat sub-grid indices (rows south to north) of a tile's SW, SE, NW and NE corners."""
    return np.array([0, n - 1, n * (n - 1), n * n - 1])


def corner_mask(n: int = SUBGRID) -> NDArray[np.bool_]:
    """(n*n,) True at the four corners of a tile's sub-grid."""
    mask = np.zeros(n * n, bool)
    mask[corner_nodes(n)] = True
    return mask


def tile_key(i: NDArray[np.integer], j: NDArray[np.integer]) -> NDArray[np.int64]:
    """One int64 per integer pair (tile or node keys, negative ones too), for set operations."""
    return np.asarray(i, np.int64) * (1 << 32) + (np.asarray(j, np.int64) & 0xFFFFFFFF)


def key_pair(key: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The integer pairs (i, j) of :func:`tile_key`'s keys."""
    key = np.asarray(key, np.int64)
    return key >> 32, (key & 0xFFFFFFFF).astype(np.uint32).view(np.int32).astype(np.int64)


class TileIndex:
    """Position of tiles by their integer indices (i, j), looked up many times: through a raster
    over their extent where they fill most of it (an area's tiles do: no sort), else sorted once."""

    DENSE = 4  # raster cells the lookup may spend per tile

    def __init__(self, i: NDArray[np.integer], j: NDArray[np.integer]) -> None:
        i, j = np.asarray(i, np.int64), np.asarray(j, np.int64)
        self._raster: NDArray[np.intp] | None = None
        if len(i):
            self._i0, self._j0 = int(i.min()), int(j.min())
            shape = (int(j.max()) - self._j0 + 1, int(i.max()) - self._i0 + 1)
            if shape[0] * shape[1] <= self.DENSE * len(i):
                self._raster = np.full(shape, -1, np.intp)
                self._raster[j - self._j0, i - self._i0] = np.arange(len(i))
                return
        key = tile_key(i, j)
        self._order = np.argsort(key)
        self._sorted = key[self._order]

    def find(self, i: NDArray[np.integer], j: NDArray[np.integer]) -> NDArray[np.intp]:
        """Index of the tile (i, j) among those indexed; −1 where there is none."""
        if self._raster is not None:
            r = np.asarray(j, np.int64) - self._j0
            c = np.asarray(i, np.int64) - self._i0
            rows, cols = self._raster.shape
            ok = (r >= 0) & (c >= 0) & (r < rows) & (c < cols)
            out = np.full(len(r), -1, np.intp)
            out[ok] = self._raster[r[ok], c[ok]]
            return out
        want = tile_key(i, j)
        out = np.full(len(want), -1, np.intp)
        if len(self._sorted) == 0:
            return out
        pos = np.minimum(np.searchsorted(self._sorted, want), len(self._sorted) - 1)
        hit = self._sorted[pos] == want
        out[hit] = self._order[pos[hit]]
        return out


@dataclass(frozen=True)
class NodeLattice:
    """Heights on the node lattice of one level: node (i0 + i, j0 + j) at
    x = (i0 + i)·spacing, y = (j0 + j)·spacing is ``z[j, i]`` (rows south to north); NaN = none."""

    z: NDArray[np.float64]
    i0: int
    j0: int
    spacing: float

    def tiles(self, n: int = SUBGRID) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]]:
        """(T, n*n) sub-grids of every whole tile, and the tile indices (i, j) of each; the lattice
        must start on a tile corner."""
        step = n - 1
        win = np.lib.stride_tricks.sliding_window_view(self.z, (n, n))[::step, ::step]
        rows, cols = win.shape[:2]
        jj, ii = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
        return (
            win.reshape(rows * cols, n * n),
            (self.i0 // step + ii.ravel()).astype(np.int64),
            (self.j0 // step + jj.ravel()).astype(np.int64),
        )

    def points(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """x, y, z of every node with a height."""
        return self._at_nodes(~np.isnan(self.z))

    def points_near(
        self, boxes: Sequence[tuple[float, float, float, float]], margin: float
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """:meth:`points` within ``margin`` m of any of ``boxes`` (x0, y0, x1, y1), in the same order
        (and a few beyond, to the next node)."""
        near = np.zeros(self.z.shape, bool)
        rows, cols = self.z.shape
        for x0, y0, x1, y1 in boxes:
            i = np.clip(
                [
                    np.floor((x0 - margin) / self.spacing) - self.i0,
                    np.ceil((x1 + margin) / self.spacing) - self.i0 + 1,
                ],
                0,
                cols,
            )
            j = np.clip(
                [
                    np.floor((y0 - margin) / self.spacing) - self.j0,
                    np.ceil((y1 + margin) / self.spacing) - self.j0 + 1,
                ],
                0,
                rows,
            )
            near[int(j[0]) : int(j[1]), int(i[0]) : int(i[1])] = True
        return self._at_nodes(near & ~np.isnan(self.z))

    def _at_nodes(
        self, mask: NDArray[np.bool_]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        jj, ii = np.nonzero(mask)
        x = ((self.i0 + ii) * self.spacing).astype(np.float64)
        return x, ((self.j0 + jj) * self.spacing).astype(np.float64), self.z[jj, ii]

    def at(self, i: NDArray[np.int64], j: NDArray[np.int64]) -> NDArray[np.float64]:
        """Heights of nodes (i, j); NaN outside the lattice or where none is stored."""
        i, j = np.broadcast_arrays(i, j)
        rows, cols = self.z.shape
        if self.z.size == 0:
            return np.full(np.shape(i), np.nan)
        ii, jj = i - self.i0, j - self.j0
        # one unsigned comparison per axis also rejects negative offsets
        ok = (ii.astype(np.uint64) < cols) & (jj.astype(np.uint64) < rows)
        return np.where(ok, self.z.ravel()[np.where(ok, jj * cols + ii, 0)], np.nan)

    def tile_nodes(self, xg: NDArray[np.int64], yg: NDArray[np.int64]) -> NDArray[np.float64]:
        """(T, SUBGRID, SUBGRID) heights of the tiles with lower-left corners (xg, yg) (rows south to
        north), NaN where none."""
        ni = np.rint(np.asarray(xg) / self.spacing).astype(np.int64) - self.i0
        nj = np.rint(np.asarray(yg) / self.spacing).astype(np.int64) - self.j0
        rows, cols = self.z.shape
        inside = (ni >= 0) & (nj >= 0) & (ni <= cols - SUBGRID) & (nj <= rows - SUBGRID)
        if inside.all():  # the usual case: one gather of whole windows
            windows = np.lib.stride_tricks.sliding_window_view(self.z, (SUBGRID, SUBGRID))
            return np.asarray(windows[nj, ni], np.float64)
        d = np.arange(SUBGRID)
        return self.at(
            (ni + self.i0)[:, None, None] + d[None, None, :], (nj + self.j0)[:, None, None] + d[None, :, None]
        )

    def corners(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Bilinear height from the tile corners (every ``SUBGRID − 1``-th node) at (x, y)."""
        step = SUBGRID - 1
        size = self.spacing * step
        u, v = x / size, y / size
        ci, cj = np.floor(u).astype(np.int64), np.floor(v).astype(np.int64)
        fu, fv = u - ci, v - cj
        out = np.zeros(np.shape(x))
        for di, dj in ((0, 0), (1, 0), (0, 1), (1, 1)):
            w = (fu if di else 1 - fu) * (fv if dj else 1 - fv)
            out += w * self.at((ci + di) * step, (cj + dj) * step)
        return out


def node_lattice(
    x: NDArray[np.float64], y: NDArray[np.float64], z: NDArray[np.float64], level: int
) -> NodeLattice:
    """Place points that lie on the node lattice of ``level`` (stored points) on it.

    Raises
    ------
    InputError
        If the lattice over the points' box would exceed :data:`tdb.raster.MAX_CELLS` nodes
        (a version spread over a vast box, read whole): a smaller area must be read.
    """
    s = node_spacing(level)
    i, j = np.rint(x / s).astype(np.int64), np.rint(y / s).astype(np.int64)
    if len(i) == 0:
        return NodeLattice(np.full((0, 0), np.nan), 0, 0, s)
    i0, j0 = int(i.min()), int(j.min())
    shape = (int(j.max()) - j0 + 1, int(i.max()) - i0 + 1)
    if shape[0] * shape[1] > MAX_CELLS:
        raise InputError(
            f"the {s:g} m node lattice over these points' {shape[1] * s / 1000:,.1f} × "
            f"{shape[0] * s / 1000:,.1f} km box needs {shape[0] * shape[1]:,} nodes (most {MAX_CELLS:,}): "
            "read a smaller area"
        )
    grid = np.full(shape, np.nan)
    grid[j - j0, i - i0] = z
    return NodeLattice(grid, i0, j0, s)
