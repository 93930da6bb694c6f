"""Elmqvist (2001/2002): an active-contour net pulled up from below the data.

The lowest point of each grid cell is the data the net sees. The net starts a
metre below the lowest point and moves only in z under three forces: elasticity
(arctan of the height differences to its four neighbours), attraction towards
its cell's lowest point (strong near it, zero beyond a cut-off range above it),
and, in the first phase only, gravitation. The sign of the total force says up
or down; strong attraction means a small step, so the net does not jump past
the point. The net is solved coarse to fine (the hierarchic scheme), each level
starting from the one before. Points near the final net are ground.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from ingest.ground.grids import Grid, lowest_per_cell
from tdb.bbox import column_range


@dataclass(frozen=True)
class ContourParams:
    cell: float = 1.0  # finest grid (m)
    levels: int = 5  # coarse-to-fine levels, each halving the cell
    elasticity: float = 1.0
    attraction: float = 2.0
    # The paper gives no figures for these three; each was chosen by leave-one-site-out on the
    # ISPRS sites (benchmarks/paper_filters_cv.py). The gravitation of the first phase earned no
    # place there: at 0 the two phases are one.
    attraction_range: float = 1.0  # cut-off (m) for points above the net, at the finest level
    gravity: float = 0.0
    step: float = 0.5  # largest move per iteration (m)
    tolerance: float = 0.005  # convergence: largest move below this (m)
    max_iterations: int = 300
    ground_distance: float = 1.25  # points within this of the net are ground (m)


def elasticity(net: NDArray[np.float64], cell: float) -> NDArray[np.float64]:
    """Sum over the four neighbours of arctan(height difference / spacing); a cell at the
    raster's edge has no force from beyond it."""
    rows, cols = net.shape
    # arctan is odd: each pair of neighbours' term is worked out once, for the one and, negated,
    # for the other (the arctan is most of a step's cost).
    down = np.zeros((rows + 1, cols))
    down[1:-1] = np.arctan(np.diff(net, axis=0) / cell)
    right = np.zeros((rows, cols + 1))
    right[:, 1:-1] = np.arctan(np.diff(net, axis=1) / cell)
    return -down[:-1] + down[1:] - right[:, :-1] + right[:, 1:]


def attraction(d: NDArray[np.float64], *, strength: float, reach: float) -> NDArray[np.float64]:
    """Force towards the data at signed distance d = point − net (NaN: no point).

    A point above the net attracts it with full strength up to ``reach`` and not
    at all beyond (the cut-off tail); a point below the net always pulls it down.
    """
    out = np.zeros(d.shape)
    has = ~np.isnan(d)
    dd = d[has]
    out[has] = np.where(dd >= 0, np.where(dd <= reach, strength, 0.0), -strength)
    return out


def relax(
    target: NDArray[np.float64], net: NDArray[np.float64], cell: float, reach: float, p: ContourParams
) -> NDArray[np.float64]:
    """Run both phases on one level; returns the converged net."""
    return _phases(target, net, lambda n: elasticity(n, cell), reach, p)


def relax_on(
    target: NDArray[np.float64],
    net: NDArray[np.float64],
    mask: NDArray[np.bool_],
    cell: float,
    reach: float,
    p: ContourParams,
) -> NDArray[np.float64]:
    """:func:`relax` on the ``mask`` cells only: a neighbour off the mask exerts no elasticity,
    as if at the cell's own height, and the net off the mask stays where it was. Costs what
    the mask holds, not the raster."""
    rows, cols = net.shape
    idx = np.flatnonzero(mask)
    compact = np.full(rows * cols, -1, np.intp)
    compact[idx] = np.arange(len(idx))
    r, c = np.divmod(idx, cols)
    n = len(idx)

    def neighbour(dr: int, dc: int, none: int) -> NDArray[np.intp]:
        rr, cc = r + dr, c + dc
        inside = (rr >= 0) & (rr < rows) & (cc >= 0) & (cc < cols)
        nb = np.where(inside, compact[np.where(inside, rr * cols + cc, 0)], -1)
        return np.where(nb >= 0, nb, none)

    # arctan is odd: the term between two neighbours is worked out once, on the cell before
    # (row or column), and taken negated by the one after. A missing neighbour after a cell is
    # the cell itself (no difference); one before it, a zero appended to the terms.
    after_row, after_col = neighbour(1, 0, -1), neighbour(0, 1, -1)
    itself = np.arange(n)
    after_row, after_col = np.where(after_row >= 0, after_row, itself), np.where(after_col >= 0, after_col, itself)
    before_row, before_col = neighbour(-1, 0, n), neighbour(0, -1, n)
    to_row, to_col = np.zeros(n + 1), np.zeros(n + 1)

    def elastic(v: NDArray[np.float64]) -> NDArray[np.float64]:
        np.arctan((v[after_row] - v) / cell, out=to_row[:n])
        np.arctan((v[after_col] - v) / cell, out=to_col[:n])
        return -to_row[before_row] + to_row[:n] - to_col[before_col] + to_col[:n]

    out = net.copy()
    out.ravel()[idx] = _phases(target.ravel()[idx], net.ravel()[idx], elastic, reach, p)
    return out


def _phases(
    target: NDArray[np.float64],
    net: NDArray[np.float64],
    elastic: Callable[[NDArray[np.float64]], NDArray[np.float64]],
    reach: float,
    p: ContourParams,
) -> NDArray[np.float64]:
    """Both phases (with gravitation, then without) of a net under ``elastic``, the sum of its
    elasticity forces, whatever shape the net is held in."""
    net = net.copy()
    for gravity in (p.gravity, 0.0):
        for _ in range(p.max_iterations):
            d = target - net
            a = attraction(d, strength=p.attraction, reach=reach)
            dz = _step(p.elasticity * elastic(net) + a - gravity, d, a, p)
            net += dz
            if dz.size == 0 or np.abs(dz).max() < p.tolerance:
                break
    return net


def _step(
    force: NDArray[np.float64], d: NDArray[np.float64], a: NDArray[np.float64], p: ContourParams
) -> NDArray[np.float64]:
    """The move the force asks for; near its point the net takes small steps and never jumps past it."""
    dz = np.sign(force) * np.minimum(p.step, np.abs(force) * p.step)
    toward = (np.sign(dz) == np.sign(d)) & (a != 0)
    return np.where(toward, np.sign(dz) * np.minimum(np.abs(dz), 0.5 * np.abs(d) + 0.001), dz)


def active_contour_net(xyz: NDArray[np.float64], *, params: ContourParams | None = None) -> tuple[Grid, NDArray]:
    """The converged net on the finest grid (rows south to north)."""
    p = params or ContourParams()
    # Finest cell: about 1.5 point spacings, so that most cells hold a point.
    lo, hi = column_range(xyz[:, :2])
    density = len(xyz) / max(float(np.prod(hi - lo)), 1.0)
    cell = max(p.cell, 1.5 / np.sqrt(density))
    fine = Grid.covering(xyz[:, :2], cell)
    net: NDArray[np.float64] | None = None
    for level in range(p.levels - 1, -1, -1):
        factor = 2**level
        grid = Grid(fine.x0, fine.y0, cell * factor, (-(-fine.shape[0] // factor), -(-fine.shape[1] // factor)))
        target = lowest_per_cell(grid, xyz)
        if net is None:
            # The first net lies below everything: only here may far points attract it.
            net = np.full(grid.shape, np.nanmin(target) - 1.0)
            reach = float(np.nanmax(target) - np.nanmin(target)) + 2.0
        else:
            reach = p.attraction_range * factor
            zoom = (grid.shape[0] / net.shape[0], grid.shape[1] / net.shape[1])
            net = ndimage.zoom(net, zoom, order=1, mode="nearest", grid_mode=True)[
                : grid.shape[0], : grid.shape[1]
            ]
        net = relax(target, net, grid.cell, reach, p)
    assert net is not None
    return fine, net[: fine.shape[0], : fine.shape[1]]


def active_contour(xyz: NDArray[np.float64], *, params: ContourParams | None = None) -> NDArray[np.bool_]:
    """Ground mask: points within ``ground_distance`` of the converged net."""
    p = params or ContourParams()
    grid, net = active_contour_net(xyz, params=p)
    return np.abs(xyz[:, 2] - grid.sample(net, xyz[:, :2])) <= p.ground_distance
