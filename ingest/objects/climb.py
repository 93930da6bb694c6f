"""Segmenting a surface by climbing (seed §2.3): every cell climbs its steepest way up, and the
cells that reach the same local maximum form one segment."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

NEIGHBOURS = ((-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1))


def climb(surface: NDArray[np.float64], mask: NDArray[np.bool_]) -> NDArray[np.intp]:
    """Label of each ``mask`` cell: the flat index of the maximum it climbs to; −1 off the mask.

    Each cell steps to its highest neighbour on the mask where that is higher than itself
    (ties broken by position, so a plateau has one maximum, not one per cell). Steps are
    followed by pointer doubling: log₂ of the longest path passes, not one per cell. The work
    is on the mask's cells only.
    """
    rows, cols = surface.shape
    at = np.flatnonzero(mask.ravel())
    out = np.full(rows * cols, -1, np.intp)
    if len(at) == 0:
        return out.reshape(rows, cols)
    compact = np.full(rows * cols, -1, np.intp)
    compact[at] = np.arange(len(at))
    # rank among the mask's cells by height, then position: unique, so ties have an order
    rank = np.empty(len(at), np.int64)
    rank[np.lexsort((at, surface.ravel()[at]))] = np.arange(len(at))
    r, c = np.divmod(at, cols)
    best = np.arange(len(at))
    best_rank = rank.copy()
    for dr, dc in NEIGHBOURS:
        rr, cc = r + dr, c + dc
        inside = (rr >= 0) & (rr < rows) & (cc >= 0) & (cc < cols)
        nb = np.where(inside, compact[np.where(inside, rr * cols + cc, 0)], -1)
        nb_rank = np.where(nb >= 0, rank[np.maximum(nb, 0)], -1)
        up = nb_rank > best_rank
        best_rank = np.where(up, nb_rank, best_rank)
        best = np.where(up, nb, best)
    parent = best
    while True:
        grand = parent[parent]
        if np.array_equal(grand, parent):
            break
        parent = grand
    out[at] = at[parent]
    return out.reshape(rows, cols)


def relabel(labels: NDArray[np.intp]) -> NDArray[np.intp]:
    """Labels renumbered 0, 1, 2 … in order of first appearance of each value; −1 stays."""
    out = np.full(labels.shape, -1, np.intp)
    on = labels >= 0
    _, inverse = np.unique(labels[on], return_inverse=True)
    out[on] = inverse
    return out
