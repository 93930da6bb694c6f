"""Nearest neighbours among plan positions: the one way a k-d tree of survey points is built."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial import cKDTree


def plan_tree(xy: ArrayLike) -> cKDTree:
    """A k-d tree of plan positions (N, 2), for exact nearest-neighbour queries.

    Built by sliding-midpoint splits, without the median search of scipy's default balanced
    tree and without shrinking each node to its points' bounds: survey points lie spread
    evenly enough that neither makes the queries faster, and together they are most of the
    build time. A survey's trees are often built for a few thousand queries among millions
    of points, where the build is the cost."""
    return cKDTree(np.asarray(xy, np.float64), balanced_tree=False, compact_nodes=False)
