"""How far a crown's highest return falls short of the tree's top, measured on the survey itself.

A tree's height is read from its highest return, and that return lies under the top: the pulses
seldom hit the apex, and a first return reaches some way into the crown. The shortfall shrinks as
the crowns are sampled more densely, so the survey measures it by sampling itself more thinly:
its crown returns are dealt into four parts by a hash of their coordinates, and over all its
trees the highest return of half of them, and of a quarter, fall short of the highest of all by
mean gaps g₁ (all to half) and g₂ (half to quarter).

The shortfall of the highest of n returns has two terms. A crown's curvature alone puts it at
a paraboloid's depth over its returns, D / n (the highest of n returns spread evenly over a
depth D); the returns' depth into the crown, added to it, makes the lowest shortfalls rarer, as
the square of their size, so that term falls as n^(−½). Over a crown of depth D whose returns
reach a depth λ into it, it is about √(λ D / n). So b(n) = a + β with a ∝ 1/n and β ∝ 1/√n at the
survey's n, and the gaps give both: g₁ = a + (√2 − 1) β and g₂ = 2a + (2 − √2) β. Where the gaps
fall faster than 1/n or slower than 1/√n (noise in a few crowns) the one term that fits them is
taken. A single power of n fitted to the two gaps reads the local power between a quarter and a
half of the returns, steeper than at all of them, and so falls short of the shortfall itself.
The gaps are averaged over several deals, each by another hash: their ratio, which sets the two
terms' shares, is too uncertain from one.

Per crown, each term with the crown's own figures: a crown's depth grows with its tree's height,
so crown k gets A h_k / n_k + B √(h_k / n_k), its highest return's height h_k and its returns
n_k, with A and B such that the crowns measured above average the survey's a and β: a small crown
on a tall tree falls further short than a broad one on a low tree.

A crown's shortfall is less than its depth, and its depth less than its tree's height, so a crown
of one return falls short by less than its height: A + B / √h_k, averaged over the crowns
measured, is under one. Where it is not, the gaps are no sampling shortfall (a survey of
artefacts, a ground model bridging wide gaps under tall objects): no shortfall is added.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from ingest.noise import coordinate_hash
from tdb.tin import group_starts

PARTS = 4  # halves and quarters of each crown's returns
# Deals averaged, each by another hash: one deal's gaps are too noisy for their ratio, which
# sets how the shortfall divides between its two terms.
DEALS = 8
# Returns per crown that can hold the maximum of one of its quarters: the highest of this many
# misses a quarter with chance (3/4)^64, under 1e-8.
HIGHEST = 64
MAX_SHARE = 1.0  # a crown of one return falls short by less than its tree's height (the module's text)
_ROOT2 = float(np.sqrt(2.0))


class SurveyLaw(NamedTuple):
    """The survey's mean shortfall in its two terms (m), and the crowns they were measured on."""

    curvature: float  # a: falls as 1 / n
    depth: float  # β: falls as 1 / √n
    measured: NDArray[np.intp]


_NONE = SurveyLaw(0.0, 0.0, np.zeros(0, np.intp))


def sampling_shortfall(segment: NDArray[np.intp], height: NDArray[np.float64], xy: NDArray[np.float64]) -> float:
    """The mean shortfall (m) of a crown's highest return below its top, over the crowns of one
    survey: ``segment`` gives each return's crown (−1: none), ``height`` its height, ``xy`` its
    plan position. 0 where no crown has returns in all four parts, or the gaps do not shrink as
    the sampling grows (no shortfall to measure)."""
    law = _survey_law(segment, height, xy)
    return law.curvature + law.depth


def crown_shortfalls(
    segment: NDArray[np.intp], height: NDArray[np.float64], xy: NDArray[np.float64], *, n: int
) -> NDArray[np.float64]:
    """The shortfall (m) of each crown 0 … ``n`` − 1: the survey's two terms
    (:func:`sampling_shortfall`) with each crown's own height and number of returns (the module's
    text); 0 for a crown with no returns, and for all where the survey has no shortfall to measure."""
    seg = np.asarray(segment, np.intp)
    law = _survey_law(seg, height, xy)
    if law.curvature + law.depth == 0.0 or n == 0:
        return np.zeros(n)
    on = seg >= 0
    count = np.bincount(seg[on], minlength=n).astype(float)
    top = np.zeros(n)
    np.maximum.at(top, seg[on], np.asarray(height, float)[on])
    top = np.maximum(top, 0.0)
    per_return = np.where(count > 0, top / np.maximum(count, 1.0), 0.0)
    terms = (per_return, np.sqrt(per_return))  # curvature, depth
    measured = law.measured
    scales = [float(np.mean(w[measured])) if len(measured) else 0.0 for w in terms]
    if min(scales) <= 0:
        return np.full(n, law.curvature + law.depth)
    a, b = law.curvature / scales[0], law.depth / scales[1]
    tall = top[measured]
    tall = tall[tall > 0]
    if not len(tall) or a + b * float(np.mean(1.0 / np.sqrt(tall))) > MAX_SHARE:
        return np.zeros(n)
    return a * terms[0] + b * terms[1]


def _survey_law(segment: NDArray[np.intp], height: NDArray[np.float64], xy: NDArray[np.float64]) -> SurveyLaw:
    """The survey's mean shortfall in its two terms, and the crowns its gaps were measured on."""
    seg = np.asarray(segment, np.intp)
    on = seg >= 0
    if not on.any():
        return _NONE
    keep = _highest(seg[on], np.asarray(height, float)[on], HIGHEST)
    seg, h, xy = seg[on][keep], np.asarray(height, float)[on][keep], np.asarray(xy, float)[on][keep]
    deals = [_gaps(seg, h, xy, deal) for deal in range(DEALS)]
    gaps = np.array([d[:2] for d in deals])
    if np.isnan(gaps).all():
        return _NONE
    g1, g2 = np.nanmean(gaps, axis=0)
    if g1 <= 0 or g2 <= 0:
        return _NONE
    curvature, depth = _two_terms(float(g1), float(g2))
    return SurveyLaw(curvature, depth, deals[0][2])


def _two_terms(g1: float, g2: float) -> tuple[float, float]:
    """a and β from the gaps g₁ = a + (√2 − 1) β and g₂ = 2a + (2 − √2) β, neither negative."""
    depth = (2 * g1 - g2) / (2 * (_ROOT2 - 1) - (2 - _ROOT2))
    curvature = g1 - (_ROOT2 - 1) * depth
    if depth < 0:  # the gaps fall as 1 / n or faster
        return g1, 0.0
    if curvature < 0:  # as 1 / √n or slower
        return 0.0, g1 / (_ROOT2 - 1)
    return curvature, depth


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
