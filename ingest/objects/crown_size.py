"""A crown's diameter: from its area where it stands alone, from its free edge where it meets others.

Where two crowns meet, the canopy shows each only up to the line where their surfaces cross, and
the segment's area misses what the other crown covers; where the segmentation places that line
wrong, one crown gains what the other loses. The crown's free edge, where it meets the ground or
the gaps of the canopy, is its own: a circle fitted to it gives the diameter, as a forester
reads a crown's spread from its outer edge. The fit needs the free edge to run at least half way
round; a crown hemmed in by others keeps its area's diameter.

A crown reaches down to its base, a share of its tree's height; the cells of a segment lower than
that are a lower crown's, which the taller crown's flank captured where the climb from the lower
crown's edge led up it (most often between sparse returns). They are canopy of no measured crown
(:data:`UNDER_BASE`): no part of the taller crown's diameter, and no free edge either.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tdb.sort import scatter_max

MIN_EDGE_CELLS = 6  # fewer free edge cells fit no circle
MIN_ARC = np.pi  # rad: the free edge must run at least half way round the fitted centre
# The fitted radius against the area's: outside these bounds the edge is no circle's arc
RADIUS_BOUNDS = (0.5, 2.0)
NO_CROWN = -1  # a label: no crown, the ground or a gap of the canopy
UNDER_BASE = -2  # a label: canopy under the base of the crown that captured it


def under_base(labels: NDArray[np.intp], canopy: NDArray[np.float64], share: float | None) -> NDArray[np.intp]:
    """``labels`` (segments 0 … n − 1, :data:`NO_CROWN` elsewhere) with each segment's cells lower
    than ``share`` × its highest cell of ``canopy`` (heights over the ground) set to
    :data:`UNDER_BASE`; None: as they are."""
    out = np.array(labels, np.intp, copy=True)
    on = np.flatnonzero(out >= 0)  # the work is on the crowns' cells only
    if share is None or len(on) == 0:
        return out
    seg = out.ravel()[on]
    height = canopy.ravel()[on]
    height = np.where(np.isfinite(height), height, -np.inf)
    apex = np.full(int(seg.max()) + 1, -np.inf)
    scatter_max(apex, seg, height)
    top = apex[seg]
    # a segment keeps its highest cell whatever the heights' sign: every segment keeps a crown
    out.ravel()[on[(height < share * top) & (height < top)]] = UNDER_BASE
    return out


def crown_diameters(labels: NDArray[np.intp], cell: float) -> NDArray[np.float64]:
    """Crown diameter (m) of each segment 0 … n − 1 of ``labels`` (:data:`NO_CROWN`, :data:`UNDER_BASE`),
    cells of ``cell`` m.

    The diameter of the circle of the segment's area; for a segment that meets another, the
    circle fitted (least squares, Kåsa) to the centres of its free edge cells, half a cell out to
    their outer edges, where that edge runs at least :data:`MIN_ARC` round the centre.
    """
    n = int(labels.max()) + 1 if labels.size and (labels >= 0).any() else 0
    if n == 0:
        return np.zeros(0)
    cells = np.bincount(labels[labels >= 0], minlength=n)
    by_area = 2 * np.sqrt(cells / np.pi)  # in cells
    free, meets = _edges(labels, n)
    j, i = np.nonzero(free)
    k = labels[free]
    radius, arc = _fitted_circles(i.astype(np.float64) + 0.5, j.astype(np.float64) + 0.5, k, n)
    fits = (
        meets
        & (np.bincount(k, minlength=n) >= MIN_EDGE_CELLS)
        & (arc >= MIN_ARC)
        & (radius >= RADIUS_BOUNDS[0] * by_area / 2)
        & (radius <= RADIUS_BOUNDS[1] * by_area / 2)
    )
    return np.where(fits, 2 * (radius + 0.5), by_area) * cell


def _edges(labels: NDArray[np.intp], n: int) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """The crown cells with a 4-neighbour outside every crown (the free edge), and per segment
    whether any of its cells has a 4-neighbour in another segment or under a crown's base."""
    pad = np.pad(labels, 1, constant_values=NO_CROWN)
    neighbours = (pad[:-2, 1:-1], pad[2:, 1:-1], pad[1:-1, :-2], pad[1:-1, 2:])
    inside = labels >= 0
    free = inside & np.logical_or.reduce([nb == NO_CROWN for nb in neighbours])
    shared = inside & np.logical_or.reduce([(nb != NO_CROWN) & (nb != labels) for nb in neighbours])
    return free, np.bincount(labels[shared], minlength=n) > 0


def _fitted_circles(
    x: NDArray[np.float64], y: NDArray[np.float64], k: NDArray[np.intp], n: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Per group ``k`` of points (x, y): the radius of the least-squares circle (Kåsa: the
    algebraic fit, linear in its unknowns) and the arc the points span round its centre (2π less
    the widest gap between them); NaN radius and 0 arc where the fit is singular."""
    count = np.bincount(k, minlength=n).astype(np.float64)
    safe = np.maximum(count, 1)
    # about each group's mean, for a well-conditioned system
    u = x - (np.bincount(k, x, n) / safe)[k]
    v = y - (np.bincount(k, y, n) / safe)[k]
    w = u**2 + v**2

    def s(a: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.bincount(k, a, n).astype(np.float64)

    suu, svv, suv, su, sv = s(u * u), s(v * v), s(u * v), s(u), s(v)
    a = np.stack([np.stack([suu, suv, su], -1), np.stack([suv, svv, sv], -1), np.stack([su, sv, count], -1)], -2)
    b = -np.stack([s(u * w), s(v * w), s(w)], -1)
    ok = np.abs(np.linalg.det(a)) > 1e-9
    sol = np.full((n, 3), np.nan)
    sol[ok] = np.linalg.solve(a[ok], b[ok][..., None])[..., 0]
    cu, cv = -sol[:, 0] / 2, -sol[:, 1] / 2
    with np.errstate(invalid="ignore"):
        radius = np.sqrt(cu**2 + cv**2 - sol[:, 2])
    angle = np.arctan2(v - np.nan_to_num(cv)[k], u - np.nan_to_num(cu)[k])
    order = np.lexsort((angle, k))
    ks, th = k[order], angle[order]
    gap = np.where(ks[1:] == ks[:-1], np.diff(th), 0.0)
    widest = np.zeros(n)
    np.maximum.at(widest, ks[1:], gap)
    first = np.r_[True, ks[1:] != ks[:-1]]
    last = np.r_[ks[1:] != ks[:-1], True]
    np.maximum.at(widest, ks[first], th[first] + 2 * np.pi - th[last])
    arc = np.where(ok & (count >= 2), 2 * np.pi - widest, 0.0)
    return np.where(ok, radius, np.nan), arc
