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


def centreline(x: NDArray[np.float64], y: NDArray[np.float64], *, link: float) -> shapely.Geometry:
    """A (Multi)LineString through the points (x, y), joining points at most ``link`` apart.

    Returns an empty LineString for fewer than two distinct points.
    """
    pts = np.unique(np.column_stack([x, y]).round(6), axis=0)
    if len(pts) < 2:
        return shapely.LineString()
    tree = cKDTree(pts)
    dist = tree.sparse_distance_matrix(tree, link, output_type="coo_matrix")
    upper = dist.row < dist.col
    graph = coo_matrix((dist.data[upper], (dist.row[upper], dist.col[upper])), shape=(len(pts), len(pts)))
    mst = minimum_spanning_tree(graph).tocoo()
    a, b = mst.row, mst.col
    for _ in range(SPUR_ROUNDS):
        degree = np.bincount(np.concatenate([a, b]), minlength=len(pts))
        # A spur: a leaf hanging off a junction. Ends of the main line hang off degree-2 nodes and stay.
        spur = ((degree[a] == 1) & (degree[b] >= 3)) | ((degree[b] == 1) & (degree[a] >= 3))
        if not spur.any():
            break
        a, b = a[~spur], b[~spur]
    if len(a) == 0:
        return shapely.LineString()
    segments = shapely.multilinestrings(np.stack([pts[a], pts[b]], axis=1))
    return shapely.line_merge(segments)


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
