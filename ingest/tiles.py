"""The dense ground model sampled on the node lattice of each pyramid level (see :mod:`tdb.tiles`)."""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from tdb.raster import Raster
from tdb.tiles import SUBGRID, NodeLattice, node_spacing


def node_grid(dtm: Raster, level: int, *, n: int = SUBGRID) -> NodeLattice:
    """Sample the dense model on the node lattice of ``level`` (m) covering its data.

    Coarser lattices are sampled from the model smoothed over the node spacing
    (NaN-aware), so that a 16 m tile sees the form of the terrain, not its noise.
    """
    s = node_spacing(level, n=n)
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
    z = _on_posts(source, xs, ys)
    if z is None:
        gx, gy = np.meshgrid(xs, ys)
        z = source.sample(gx.ravel(), gy.ravel()).reshape(gx.shape)
    return NodeLattice(z, ix0, iy0, s)


def _on_posts(raster: Raster, xs: np.ndarray, ys: np.ndarray) -> np.ndarray | None:
    """The raster's values at the grid ``xs`` × ``ys`` (rows south to north) where every node lies
    on a post (what a bilinear read there gives, without one), NaN beyond the raster; None where
    the nodes fall between posts."""
    cx, cy = raster.centres()
    col = (xs - cx[0]) / raster.cell
    row = (cy[0] - ys) / raster.cell
    if not (np.allclose(col, np.rint(col), atol=1e-6) and np.allclose(row, np.rint(row), atol=1e-6)):
        return None
    col, row = np.rint(col).astype(np.int64), np.rint(row).astype(np.int64)
    rows, cols = raster.shape
    ok_c, ok_r = (col >= 0) & (col < cols), (row >= 0) & (row < rows)
    out = np.full((len(ys), len(xs)), np.nan)
    out[np.ix_(ok_r, ok_c)] = raster.data[np.ix_(row[ok_r], col[ok_c])]
    return out


def _smoothed(dtm: Raster, *, sigma: float) -> Raster:
    data = dtm.data
    valid = ~np.isnan(data)
    num = ndimage.gaussian_filter(np.where(valid, data, 0.0), sigma, mode="nearest")
    den = ndimage.gaussian_filter(valid.astype(float), sigma, mode="nearest")
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(valid, num / den, np.nan)
    return Raster(out, dtm.x0, dtm.y1, dtm.cell, dtm.crs)
