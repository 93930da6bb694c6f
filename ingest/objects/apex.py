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
its curvature over π times the density), and is held there.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ingest.noise import coordinate_hash

PARTS = 4  # halves and quarters of each crown's returns
ALPHA = (0.5, 1.0)  # the shortfall's power of the density: depth into the crown, the crown's curvature


def sampling_shortfall(segment: NDArray[np.intp], height: NDArray[np.float64], xy: NDArray[np.float64]) -> float:
    """The mean shortfall (m) of a crown's highest return below its top, over the crowns of one
    survey: ``segment`` gives each return's crown (−1: none), ``height`` its height, ``xy`` its
    plan position. 0 where no crown has returns in all four parts, or the gaps do not shrink as
    the sampling grows (no shortfall to measure)."""
    seg = np.asarray(segment, np.intp)
    on = seg >= 0
    if not on.any():
        return 0.0
    seg, h = seg[on], np.asarray(height, float)[on]
    part = (coordinate_hash(np.asarray(xy, float)[on]) % np.uint64(PARTS)).astype(np.intp)
    top = np.full((int(seg.max()) + 1, PARTS), -np.inf)
    np.maximum.at(top, (seg, part), h)
    full = top.max(axis=1)
    halves = np.stack([top[:, :2].max(axis=1), top[:, 2:].max(axis=1)], axis=1)
    ok = np.isfinite(top).all(axis=1)
    if not ok.any():
        return 0.0
    g1 = float(np.mean(full[ok] - halves[ok].mean(axis=1)))
    g2 = float(np.mean(halves[ok].mean(axis=1) - top[ok].mean(axis=1)))
    if g1 <= 0 or g2 <= 0:
        return 0.0
    alpha = float(np.clip(np.log2(g2 / g1), *ALPHA))
    return g1 / (2**alpha - 1)
