"""Scoring found objects against a truth: point classes, building footprints, trees."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

MATCH = 1.5  # m: a found tree matches a true one whose top is this close (one to one)
MIN_HEIGHT, MIN_CROWN = 5.0, 3.0  # m: the trees scored (issue 28)


@dataclass(frozen=True)
class TreeScore:
    recall: float
    precision: float
    f1: float
    truth: int
    found: int
    position_rmse: float
    height_rmse: float
    height_bias: float
    diameter_rmse: float
    diameter_bias: float


def _rmse(a: NDArray[np.float64]) -> float:
    return float(np.sqrt(np.mean(a**2))) if len(a) else float("nan")


def score_trees(truth: NDArray[np.float64], found: NDArray[np.float64], *, diameters: bool = True) -> TreeScore:
    """``truth`` and ``found``: (n, 4) x, y, height, crown diameter (NaN where unknown).

    Trees are matched one to one within :data:`MATCH` m, nearest first (an assignment). Recall
    is over the true trees of at least :data:`MIN_HEIGHT` m and :data:`MIN_CROWN` m crowns;
    precision over the found trees as large, less those matched to a smaller true tree (a small
    tree found is not a false one).
    """
    d = np.hypot(truth[:, None, 0] - found[None, :, 0], truth[:, None, 1] - found[None, :, 1])
    cost = np.where(d <= MATCH, d, 1e6)
    r, c = linear_sum_assignment(cost) if cost.size else (np.zeros(0, int), np.zeros(0, int))
    ok = cost[r, c] < 1e5
    r, c = r[ok], c[ok]
    big_t = (truth[:, 2] >= MIN_HEIGHT) & ~(truth[:, 3] < MIN_CROWN)
    big_f = (found[:, 2] >= MIN_HEIGHT) & ~(found[:, 3] < MIN_CROWN)
    match_t = np.full(len(truth), -1)
    match_t[r] = c
    match_f = np.full(len(found), -1)
    match_f[c] = r
    recall = float((match_t[big_t] >= 0).mean()) if big_t.any() else float("nan")
    counted = big_f & ~((match_f >= 0) & ~big_t[np.maximum(match_f, 0)])
    precision = float((match_f[counted] >= 0).mean()) if counted.any() else float("nan")
    f1 = 2 * recall * precision / (recall + precision) if recall + precision > 0 else 0.0
    sel = big_t[r]
    dd = found[c, 3] - truth[r, 3]
    dh = found[c, 2] - truth[r, 2]
    return TreeScore(
        recall,
        precision,
        f1,
        int(big_t.sum()),
        int(counted.sum()),
        _rmse(np.hypot(*(truth[r, :2] - found[c, :2]).T)[sel]),
        _rmse(dh[sel]),
        float(np.mean(dh[sel])) if sel.any() else float("nan"),
        _rmse(dd[sel]) if diameters else float("nan"),
        float(np.mean(dd[sel])) if diameters and sel.any() else float("nan"),
    )


def footprint_iou(truth: list[shapely.Geometry], found: list[shapely.Geometry]) -> list[float]:
    """Per true footprint, the intersection over union with the found footprint that overlaps it most."""
    out = []
    for t in truth:
        best = 0.0
        for f in found:
            if t.intersects(f):
                best = max(best, t.intersection(f).area / t.union(f).area)
        out.append(best)
    return out
