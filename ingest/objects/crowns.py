"""Choosing the smoothing scale per crown (seed §2.3) by fitting paraboloids.

A crown seen from above is close to a paraboloid of revolution. Where a segment of a coarser
scale holds several segments of a finer one, the finer split is kept only if one paraboloid
per piece describes the canopy better than one for the whole, by more than the extra
parameters cost: the Bayesian information criterion, the description-length idea of
Sohn & Dowman applied to crowns.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ingest.objects.climb import relabel

PARAMETERS = 4  # a + b x + c y + d (x² + y²)


@dataclass(frozen=True)
class Fits:
    """Least-squares paraboloids per segment: residual sum of squares (floored by the noise),
    cell count."""

    rss: NDArray[np.float64]
    count: NDArray[np.float64]


@dataclass(frozen=True)
class Paraboloids:
    """Least-squares paraboloids of revolution per segment: ``beta`` (n, 4) the coefficients of
    1, u, v and u² + v² about the segment's mean cell (``centre``, (n, 2)), and its cell count."""

    beta: NDArray[np.float64]
    centre: NDArray[np.float64]
    count: NDArray[np.float64]

    def at(self, k: NDArray[np.intp], x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        """The height of paraboloid ``k`` at (x, y), per point."""
        u, v = x - self.centre[k, 0], y - self.centre[k, 1]
        b = self.beta[k]
        return b[:, 0] + b[:, 1] * u + b[:, 2] * v + b[:, 3] * (u * u + v * v)


def fit_paraboloids(
    labels: NDArray[np.intp], xy: tuple[NDArray[np.float64], NDArray[np.float64]], z: NDArray[np.float64], n: int
) -> Paraboloids:
    """Fit one paraboloid of revolution per label 0 … n−1 to the cells (x, y, z)."""
    x, y = xy
    count = np.bincount(labels, minlength=n).astype(float)
    safe = np.maximum(count, 1)
    xm = np.bincount(labels, weights=x, minlength=n) / safe
    ym = np.bincount(labels, weights=y, minlength=n) / safe
    u, v = x - xm[labels], y - ym[labels]
    design = np.stack([np.ones_like(u), u, v, u * u + v * v], axis=1)
    gram = np.zeros((n, PARAMETERS, PARAMETERS))
    rhs = np.zeros((n, PARAMETERS))
    for i in range(PARAMETERS):
        rhs[:, i] = np.bincount(labels, weights=design[:, i] * z, minlength=n)
        for j in range(i, PARAMETERS):
            gram[:, i, j] = gram[:, j, i] = np.bincount(labels, weights=design[:, i] * design[:, j], minlength=n)
    gram += 1e-9 * np.eye(PARAMETERS)
    beta = np.linalg.solve(gram, rhs[..., None])[..., 0]
    return Paraboloids(np.asarray(beta, np.float64), np.stack([xm, ym], axis=1).astype(np.float64), count)


def paraboloids(
    labels: NDArray[np.intp],
    xy: tuple[NDArray[np.float64], NDArray[np.float64]],
    z: NDArray[np.float64],
    n: int,
    *,
    noise: float,
) -> Fits:
    """Fit one paraboloid of revolution per label 0 … n−1 to the cells (x, y, z). ``noise`` (m)
    floors each cell's residual, so a perfect fit of a few cells does not read as infinitely
    better."""
    fits = fit_paraboloids(labels, xy, z, n)
    resid = z - fits.at(labels, *xy)
    rss = np.bincount(labels, weights=resid**2, minlength=n)
    return Fits(np.maximum(rss, fits.count * noise**2), fits.count)


def choose_scales(
    coarse_to_fine: list[NDArray[np.intp]],
    canopy: NDArray[np.float64],
    cell: float,
    *,
    noise: float,
    min_cells: int,
) -> NDArray[np.intp]:
    """One segmentation from segmentations at several scales (coarsest first): each segment is
    split into the next finer scale's pieces where the paraboloids say so."""
    current = relabel(coarse_to_fine[0])
    on = current >= 0
    rows, cols = np.nonzero(on)
    x, y, z = (cols * cell).astype(float), (rows * cell).astype(float), canopy[on]
    for finer in coarse_to_fine[1:]:
        parent = current[on]
        pieces = _pieces(parent, finer[on], min_cells)
        n_parent = int(parent.max()) + 1
        n_piece = int(pieces.max()) + 1
        whole_fit = paraboloids(parent, (x, y), z, n_parent, noise=noise)
        piece_fit = paraboloids(pieces, (x, y), z, n_piece, noise=noise)
        piece_parent = np.zeros(n_piece, np.intp)
        piece_parent[pieces] = parent
        k = np.bincount(piece_parent, minlength=n_parent)
        rss_split = np.bincount(piece_parent, weights=piece_fit.rss, minlength=n_parent)
        count = whole_fit.count
        logn = np.log(np.maximum(count, 2))
        whole = count * np.log(whole_fit.rss / np.maximum(count, 1)) + PARAMETERS * logn
        split = count * np.log(rss_split / np.maximum(count, 1)) + PARAMETERS * k * logn
        take = (k > 1) & (split < whole)
        new = np.where(take[parent], n_parent + pieces, parent)
        current = np.full(current.shape, -1, np.intp)
        current[on] = new
        current = relabel(current)
    return current


def _pieces(parent: NDArray[np.intp], finer: NDArray[np.intp], min_cells: int) -> NDArray[np.intp]:
    """Pieces (parent, finer segment), numbered 0 …; a piece of fewer than ``min_cells`` cells
    joins the largest piece of its parent."""
    key = parent.astype(np.int64) * (int(finer.max()) + 2) + finer + 1
    _, piece = np.unique(key, return_inverse=True)
    size = np.bincount(piece)
    owner = np.zeros(len(size), np.intp)
    owner[piece] = parent
    # the largest piece of each parent
    order = np.lexsort((size, owner))
    last = np.r_[owner[order][1:] != owner[order][:-1], True]
    largest = np.zeros(int(parent.max()) + 1, np.intp)
    largest[owner[order][last]] = order[last]
    small = size < min_cells
    target = np.where(small, largest[owner], np.arange(len(size)))
    return np.unique(target[piece], return_inverse=True)[1]
