"""The centre line of a linear object through its tiles' extreme nodes.

The tiles of one ditch include its banks and rims as well as its bottom, and each
has its own break line, so the union of their break lines runs two or three times
along the ditch. The lowest node of each tile (the highest for a ridge) lies on
the bottom or close to it; a minimum spanning tree over those nodes, with short
spurs at its junctions cut off, is the line a surveyor would draw.
"""

from __future__ import annotations

import numpy as np
import shapely
from numpy.typing import NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import minimum_spanning_tree
from scipy.spatial import cKDTree

SPUR_ROUNDS = 2  # spur edges cut, one layer per round


def centrelines(
    x: NDArray[np.float64], y: NDArray[np.float64], group: NDArray[np.intp], *, link: float, count: int
) -> list[shapely.Geometry]:
    """A (Multi)LineString through the points (x, y) of each of ``count`` groups (``group``: each
    point's), joining points of a group at most ``link`` apart; an empty LineString for a group of
    fewer than two distinct points.

    One tree and one spanning forest serve all groups: only points of the same group are
    joined, so the forest is the union of each group's own tree.
    """
    keyed = np.unique(np.column_stack([group, np.round(x, 6), np.round(y, 6)]), axis=0)
    owner, pts = keyed[:, 0].astype(np.intp), keyed[:, 1:]
    pairs = cKDTree(pts).query_pairs(link, output_type="ndarray")
    pairs = pairs[owner[pairs[:, 0]] == owner[pairs[:, 1]]]
    length = np.hypot(*(pts[pairs[:, 0]] - pts[pairs[:, 1]]).T)
    graph = coo_matrix((length, (pairs[:, 0], pairs[:, 1])), shape=(len(pts), len(pts)))
    mst = minimum_spanning_tree(graph).tocoo()
    a, b = mst.row, mst.col
    for _ in range(SPUR_ROUNDS):
        degree = np.bincount(np.concatenate([a, b]), minlength=len(pts))
        # A spur: a leaf hanging off a junction. Ends of the main line hang off degree-2 nodes and stay.
        spur = ((degree[a] == 1) & (degree[b] >= 3)) | ((degree[b] == 1) & (degree[a] >= 3))
        if not spur.any():
            break
        a, b = a[~spur], b[~spur]
    out = [shapely.LineString()] * count
    order = np.argsort(owner[a], kind="stable")
    a, b = a[order], b[order]
    starts = np.searchsorted(owner[a], np.arange(count + 1))
    for g in range(count):
        lo, hi = starts[g], starts[g + 1]
        if hi > lo:
            out[g] = shapely.line_merge(shapely.multilinestrings(np.stack([pts[a[lo:hi]], pts[b[lo:hi]]], axis=1)))
    return out


def elongation(x: NDArray[np.float64], y: NDArray[np.float64], *, level: float) -> float:
    """Long side / short side of the smallest rotated rectangle around the points.

    The short side is at least one tile (``level``): a chain one tile wide is as
    thin as tiles can tell.
    """
    rect = shapely.minimum_rotated_rectangle(shapely.multipoints(np.column_stack([x, y])))
    if not isinstance(rect, shapely.Polygon):
        return float(rect.length) / level
    c = np.asarray(rect.exterior.coords)
    sides = np.hypot(*(c[1:3] - c[0:2]).T)
    return float(sides.max() / max(float(sides.min()), level))
