"""Segmenting a surface by climbing (seed §2.3): every cell climbs its steepest way up, and the
cells that reach the same local maximum form one segment."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

_NEIGHBOURS = ((-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1))


def climb(surface: NDArray[np.float64], mask: NDArray[np.bool_]) -> NDArray[np.intp]:
    """Label of each ``mask`` cell: the flat index of the maximum it climbs to; −1 off the mask.

    Each cell steps to its highest neighbour on the mask where that is higher than itself
    (ties broken by position, so a plateau has one maximum, not one per cell). Steps are
    followed by pointer doubling: log₂ of the longest path passes, not one per cell.
    """
    rows, cols = surface.shape
    flat = np.arange(rows * cols).reshape(rows, cols)
    order = np.lexsort((flat.ravel(), np.where(mask, surface, -np.inf).ravel()))
    rank = np.empty(rows * cols, np.int64)
    rank[order] = np.arange(rows * cols)
    rank2 = np.where(mask, rank.reshape(rows, cols), -1)
    best_rank = rank2.copy()
    best = flat.copy()
    padded_rank = np.pad(rank2, 1, constant_values=-1)
    padded_flat = np.pad(flat, 1, constant_values=0)
    for dr, dc in _NEIGHBOURS:
        r = padded_rank[1 + dr : 1 + dr + rows, 1 + dc : 1 + dc + cols]
        up = r > best_rank
        best_rank = np.where(up, r, best_rank)
        best = np.where(up, padded_flat[1 + dr : 1 + dr + rows, 1 + dc : 1 + dc + cols], best)
    parent = best.ravel()
    while True:
        grand = parent[parent]
        if np.array_equal(grand, parent):
            break
        parent = grand
    return np.where(mask.ravel(), parent, -1).reshape(rows, cols)


def relabel(labels: NDArray[np.intp]) -> NDArray[np.intp]:
    """Labels renumbered 0, 1, 2 … in order of first appearance of each value; −1 stays."""
    out = np.full(labels.shape, -1, np.intp)
    on = labels >= 0
    _, inverse = np.unique(labels[on], return_inverse=True)
    out[on] = inverse
    return out
