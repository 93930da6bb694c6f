"""How far a crown's highest return falls short of the tree's top, measured on the survey itself.

A tree's height is read from its highest return, and that return lies under the top: the pulses
seldom hit the apex, and a first return reaches some way into the crown. The shortfall shrinks as
the crowns are sampled more densely, so the survey measures it by sampling itself more thinly:
its crown returns are dealt into four parts by a hash of their coordinates, and over all its
trees the highest return of half of them, and of a quarter, fall short of the highest of all by
mean gaps g₁ (all to half) and g₂ (half to quarter). For a shortfall b(n) = C n^(−α) of n returns,
g₁ = b(n) (2^α − 1) and g₂ = 2^α g₁, so α = log₂(g₂ / g₁) and b(n) = g₁ / (2^α − 1). α lies between
½ (the first return's depth into the crown dominating: the least of n depths near the apex) and
1 (the crown's curvature dominating: a paraboloid's highest of n returns falls short of its top by
its curvature over π times the density), and is held there. The gaps are averaged over several
deals, each by another hash: α is read from their ratio, which one deal leaves too uncertain.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ingest.noise import coordinate_hash
from tdb.tin import group_starts

PARTS = 4  # halves and quarters of each crown's returns
ALPHA = (0.5, 1.0)  # the shortfall's power of the density: depth into the crown, the crown's curvature
# Deals averaged, each by another hash: one deal's gaps are too noisy for their ratio, and α,
# read from it, then moves the shortfall by as much as the shortfall itself.
DEALS = 8
# Returns per crown that can hold the maximum of one of its quarters: the highest of this many
# misses a quarter with chance (3/4)^64, under 1e-8.
HIGHEST = 64


def sampling_shortfall(segment: NDArray[np.intp], height: NDArray[np.float64], xy: NDArray[np.float64]) -> float:
    """The mean shortfall (m) of a crown's highest return below its top, over the crowns of one
    survey: ``segment`` gives each return's crown (−1: none), ``height`` its height, ``xy`` its
    plan position. 0 where no crown has returns in all four parts, or the gaps do not shrink as
    the sampling grows (no shortfall to measure)."""
    seg = np.asarray(segment, np.intp)
    on = seg >= 0
    if not on.any():
        return 0.0
    keep = _highest(seg[on], np.asarray(height, float)[on], HIGHEST)
    seg, h, xy = seg[on][keep], np.asarray(height, float)[on][keep], np.asarray(xy, float)[on][keep]
    gaps = np.array([_gaps(seg, h, xy, deal) for deal in range(DEALS)])
    if np.isnan(gaps).all():
        return 0.0
    g1, g2 = np.nanmean(gaps, axis=0)
    if g1 <= 0 or g2 <= 0:
        return 0.0
    alpha = float(np.clip(np.log2(g2 / g1), *ALPHA))
    return float(g1 / (2**alpha - 1))


def _highest(seg: NDArray[np.intp], h: NDArray[np.float64], count: int) -> NDArray[np.intp]:
    """Indices of the ``count`` highest returns of each crown."""
    # one key, crown then height downwards: a float sort is several times faster than a lexsort
    order = np.argsort(seg * (np.ptp(h) + 1.0) - (h - h.min()))
    _, starts, sizes = group_starts(seg[order])
    rank = np.arange(len(order)) - np.repeat(starts, sizes)
    return order[rank < count]


def _gaps(
    seg: NDArray[np.intp], h: NDArray[np.float64], xy: NDArray[np.float64], deal: int
) -> tuple[float, float]:
    """Mean gaps (all to half, half to quarter) of the crowns' highest returns, the returns dealt
    into four parts by the hash ``deal``; NaN where no crown has returns in all four."""
    part = (coordinate_hash(xy, deal) % np.uint64(PARTS)).astype(np.intp)
    top = np.full((int(seg.max()) + 1, PARTS), -np.inf)
    np.maximum.at(top, (seg, part), h)
    ok = np.isfinite(top).all(axis=1)
    if not ok.any():
        return np.nan, np.nan
    top = top[ok]
    halves = np.stack([top[:, :2].max(axis=1), top[:, 2:].max(axis=1)], axis=1).mean(axis=1)
    return float(np.mean(top.max(axis=1) - halves)), float(np.mean(halves - top.mean(axis=1)))
