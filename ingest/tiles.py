"""The dense ground model sampled on the node lattice of each pyramid level (see :mod:`tdb.tiles`)."""

from __future__ import annotations

import numpy as np
from scipy import ndimage, sparse

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
    smooth = s > dtm.cell * 1.01
    at = _post_index(dtm, xs, ys)
    if at is not None:
        z = _smoothed_at(dtm, at, sigma=0.5 * s / dtm.cell) if smooth else _read_at(dtm.data, at)
    else:
        source = _smoothed(dtm, sigma=0.5 * s / dtm.cell) if smooth else dtm
        gx, gy = np.meshgrid(xs, ys)
        z = source.sample(gx.ravel(), gy.ravel()).reshape(gx.shape)
    return NodeLattice(z, ix0, iy0, s)


_PostIndex = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]


def _post_index(raster: Raster, xs: np.ndarray, ys: np.ndarray) -> _PostIndex | None:
    """The raster rows and columns of the grid ``xs`` × ``ys`` (rows south to north) where every
    node lies on a post, with which of them fall inside the raster; None where the nodes fall
    between posts."""
    cx, cy = raster.centres()
    col = (xs - cx[0]) / raster.cell
    row = (cy[0] - ys) / raster.cell
    if not (np.allclose(col, np.rint(col), atol=1e-6) and np.allclose(row, np.rint(row), atol=1e-6)):
        return None
    col, row = np.rint(col).astype(np.int64), np.rint(row).astype(np.int64)
    rows, cols = raster.shape
    return row, col, (row >= 0) & (row < rows), (col >= 0) & (col < cols)


def _read_at(data: np.ndarray, at: _PostIndex) -> np.ndarray:
    """``data`` at the posts ``at`` (what a bilinear read there gives, without one), NaN beyond it."""
    row, col, ok_r, ok_c = at
    out = np.full((len(row), len(col)), np.nan)
    out[np.ix_(ok_r, ok_c)] = data[np.ix_(row[ok_r], col[ok_c])]
    return out


def _smoothed_at(dtm: Raster, at: _PostIndex, *, sigma: float) -> np.ndarray:
    """:func:`_smoothed` read at the posts ``at``: the same Gaussian, worked out at the rows and
    columns wanted only (one node in 2 to 8 posts each way), as a banded matrix on each side."""
    row, col, ok_r, ok_c = at
    data = dtm.data
    valid = ~np.isnan(data)
    rows, cols = row[ok_r], col[ok_c]
    down = _gaussian_at(rows, data.shape[0], sigma)
    across = _gaussian_at(cols, data.shape[1], sigma)
    num, den = ((across @ (down @ layer).T).T for layer in (np.where(valid, data, 0.0), valid.astype(float)))
    with np.errstate(invalid="ignore", divide="ignore"):
        smoothed = np.where(valid[np.ix_(rows, cols)], num / den, np.nan)
    out = np.full((len(row), len(col)), np.nan)
    out[np.ix_(ok_r, ok_c)] = smoothed
    return out


def _gaussian_at(at: np.ndarray, length: int, sigma: float) -> sparse.csr_matrix:
    """(len(at), length) weights of :func:`scipy.ndimage.gaussian_filter1d`'s kernel (its
    truncation at 4 sigma, the "nearest" edge) centred on the positions ``at``."""
    radius = int(4.0 * sigma + 0.5)
    offsets = np.arange(-radius, radius + 1)
    kernel = np.exp(-0.5 * offsets**2 / sigma**2)
    kernel /= kernel.sum()
    src = np.clip(at[:, None] + offsets, 0, length - 1)
    out = np.repeat(np.arange(len(at)), len(offsets))
    # beyond an edge the edge post is read again: its weights add up (coo sums duplicates)
    return sparse.coo_matrix(
        (np.broadcast_to(kernel, src.shape).ravel(), (out, src.ravel())), shape=(len(at), length)
    ).tocsr()


def _smoothed(dtm: Raster, *, sigma: float) -> Raster:
    data = dtm.data
    valid = ~np.isnan(data)
    num = ndimage.gaussian_filter(np.where(valid, data, 0.0), sigma, mode="nearest")
    den = ndimage.gaussian_filter(valid.astype(float), sigma, mode="nearest")
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(valid, num / den, np.nan)
    return Raster(out, dtm.x0, dtm.y1, dtm.cell, dtm.crs)
