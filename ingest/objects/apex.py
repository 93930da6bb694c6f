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

Per crown, the same law with the crown's own terms: a paraboloid's shortfall is its depth over
its returns (k / (π ρ) = D / n for a crown of depth D = k R² and n = ρ π R² returns), and a
crown's depth grows with its tree's height. So each crown gets b_k = c h_k n_k^(−α), its highest
return's height h_k and its returns n_k, with c such that the crowns measured above average the
survey's b: a small crown on a tall tree falls further short than a broad one on a low tree.

A crown's shortfall is less than its depth, and its depth less than its tree's height, so c, the
share of its height that a crown of one return falls short, is under one. Where the crowns
measured give c over one, the gaps are no sampling shortfall (a survey of artefacts, a ground
model bridging wide gaps under tall objects): no shortfall is added.
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
MAX_SHARE = 1.0  # c: a crown's shortfall is less than its tree's height (the module's text)


def sampling_shortfall(segment: NDArray[np.intp], height: NDArray[np.float64], xy: NDArray[np.float64]) -> float:
    """The mean shortfall (m) of a crown's highest return below its top, over the crowns of one
    survey: ``segment`` gives each return's crown (−1: none), ``height`` its height, ``xy`` its
    plan position. 0 where no crown has returns in all four parts, or the gaps do not shrink as
    the sampling grows (no shortfall to measure)."""
    return _survey_law(segment, height, xy)[0]


def crown_shortfalls(
    segment: NDArray[np.intp], height: NDArray[np.float64], xy: NDArray[np.float64], *, n: int
) -> NDArray[np.float64]:
    """The shortfall (m) of each crown 0 … ``n`` − 1: the survey's law (:func:`sampling_shortfall`)
    with each crown's own height and number of returns (the module's text); 0 for a crown with no
    returns, and for all where the survey has no shortfall to measure."""
    seg = np.asarray(segment, np.intp)
    mean, alpha, measured = _survey_law(seg, height, xy)
    if mean == 0.0 or n == 0:
        return np.zeros(n)
    on = seg >= 0
    count = np.bincount(seg[on], minlength=n).astype(float)
    top = np.zeros(n)
    np.maximum.at(top, seg[on], np.asarray(height, float)[on])
    weight = np.where(count > 0, np.maximum(top, 0.0) * np.maximum(count, 1.0) ** -alpha, 0.0)
    # the first deal may have found no crown with returns in all four parts where others did
    scale = float(np.mean(weight[measured])) if len(measured) else 0.0
    if scale > 0 and mean / scale > MAX_SHARE:
        return np.zeros(n)
    return mean * weight / scale if scale > 0 else np.full(n, mean)


def _survey_law(
    segment: NDArray[np.intp], height: NDArray[np.float64], xy: NDArray[np.float64]
) -> tuple[float, float, NDArray[np.intp]]:
    """The survey's mean shortfall, its power α, and the crowns its gaps were measured on."""
    seg = np.asarray(segment, np.intp)
    on = seg >= 0
    none = (0.0, ALPHA[0], np.zeros(0, np.intp))
    if not on.any():
        return none
    keep = _highest(seg[on], np.asarray(height, float)[on], HIGHEST)
    seg, h, xy = seg[on][keep], np.asarray(height, float)[on][keep], np.asarray(xy, float)[on][keep]
    deals = [_gaps(seg, h, xy, deal) for deal in range(DEALS)]
    gaps = np.array([d[:2] for d in deals])
    if np.isnan(gaps).all():
        return none
    g1, g2 = np.nanmean(gaps, axis=0)
    if g1 <= 0 or g2 <= 0:
        return none
    alpha = float(np.clip(np.log2(g2 / g1), *ALPHA))
    return float(g1 / (2**alpha - 1)), alpha, deals[0][2]


def _highest(seg: NDArray[np.intp], h: NDArray[np.float64], count: int) -> NDArray[np.intp]:
    """Indices of the ``count`` highest returns of each crown."""
    # one key, crown then height downwards: a float sort is several times faster than a lexsort
    order = np.argsort(seg * (np.ptp(h) + 1.0) - (h - h.min()))
    _, starts, sizes = group_starts(seg[order])
    rank = np.arange(len(order)) - np.repeat(starts, sizes)
    return order[rank < count]


def _gaps(
    seg: NDArray[np.intp], h: NDArray[np.float64], xy: NDArray[np.float64], deal: int
) -> tuple[float, float, NDArray[np.intp]]:
    """Mean gaps (all to half, half to quarter) of the crowns' highest returns, the returns dealt
    into four parts by the hash ``deal``, and the crowns with returns in all four (the gaps are
    NaN where there is none)."""
    part = (coordinate_hash(xy, deal) % np.uint64(PARTS)).astype(np.intp)
    top = np.full((int(seg.max()) + 1, PARTS), -np.inf)
    np.maximum.at(top, (seg, part), h)
    ok = np.isfinite(top).all(axis=1)
    if not ok.any():
        return np.nan, np.nan, np.zeros(0, np.intp)
    top = top[ok]
    halves = np.stack([top[:, :2].max(axis=1), top[:, 2:].max(axis=1)], axis=1).mean(axis=1)
    return float(np.mean(top.max(axis=1) - halves)), float(np.mean(halves - top.mean(axis=1))), np.flatnonzero(ok)
