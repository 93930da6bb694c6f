"""The centre line of a linear object through its tiles' extreme nodes.

The tiles of one ditch include its banks and rims as well as its bottom, and each
has its own break line, so the union of their break lines runs two or three times
along the ditch. The lowest node of each tile (the highest for a ridge) lies on
the bottom or close to it; a minimum spanning tree over those nodes, with short
spurs at its junctions cut off, is the line a surveyor would draw.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components, dijkstra, minimum_spanning_tree
from scipy.spatial import cKDTree

SPUR_ROUNDS = 2  # spur edges cut, one layer per round
# Arms of a junction headed more apart than this (degrees) are distinct lines: rails of a line two
# tiles wide head a few degrees apart at an arm's reach, tributaries join at any angle.
ARM_ANGLE = 45.0
# A line that turns by more than this (degrees) between arms of an arm's length is cut there too,
# at an acute corner, where one line may run on into another (None: cut only where three arms
# meet). Chosen by leave-one-scene-out (benchmarks/arms_cv.py --grid bend).
BEND: float | None = 90.0


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
    mst = _spanning_tree(pts, link, owner=owner).tocoo()
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


def _spanning_tree(pts: NDArray[np.float64], link: float, *, owner: NDArray[np.intp] | None = None) -> Any:
    """The minimum spanning forest (sparse, one direction) of the points ``pts`` joined at most
    ``link`` apart, and only within the same ``owner`` where given."""
    pairs = cKDTree(pts).query_pairs(link, output_type="ndarray")
    if owner is not None:
        pairs = pairs[owner[pairs[:, 0]] == owner[pairs[:, 1]]]
    length = np.hypot(*(pts[pairs[:, 0]] - pts[pairs[:, 1]]).T)
    return minimum_spanning_tree(coo_matrix((length, (pairs[:, 0], pairs[:, 1])), shape=(len(pts), len(pts))))


def branches(
    x: NDArray[np.float64], y: NDArray[np.float64], *, link: float, reach: float
) -> list[NDArray[np.intp]]:
    """The points (x, y) of one object split where distinct lines meet: at a junction of its
    spanning tree (points joined at most ``link`` apart) from which three or more arms run at
    least ``reach`` on, headed more than :data:`ARM_ANGLE` apart, and at acute corners
    (:func:`_corners`). Each branch's point indices; the junction's points belong to every arm
    that leaves them. Points the tree cannot join (a group of tiles within reach of each other can
    hold lines farther apart than ``link``) are separate lines as well. Arms shorter than
    ``reach`` are left out; one branch of every point where the tree is one line.

    Two ridges that cross or meet are one group of touching tiles, but neither its outline nor
    the height along it is that of one form: each arm is.
    """
    everything = [np.arange(len(x))]
    if len(x) < 4 or _extent(np.column_stack([x, y])) < reach:  # no arm can run that far
        return everything
    pts, inverse = np.unique(np.column_stack([np.round(x, 6), np.round(y, 6)]), axis=0, return_inverse=True)
    mst = _spanning_tree(pts, link)
    tree = (mst + mst.T).tocsr()
    degree = np.diff(tree.indptr)
    forks = np.flatnonzero(degree >= 3)
    cut = [int(j) for j in forks[_junctions(*_arms(tree, pts, forks, reach), len(forks))]]
    if BEND is not None:
        turns = np.setdiff1d(np.flatnonzero(degree >= 2), cut)
        cut += [int(j) for j in turns[_corners(*_arms(tree, pts, turns, reach), len(turns), reach)]]
    rest = tree.tolil()
    for j in cut:
        rest[j, :] = 0
        rest[:, j] = 0
    count, label = connected_components(rest.tocsr(), directed=False)
    if count == 1:
        return everything
    out = []
    for arm in range(count):
        members = np.flatnonzero(label == arm)
        if np.isin(members, cut).any():
            continue  # a junction point left on its own
        ends = np.unique(tree[members][:, cut].nonzero()[1])
        members = np.concatenate([members, np.asarray(cut, dtype=np.intp)[ends]])
        if _extent(pts[members]) >= reach:
            out.append(np.flatnonzero(np.isin(inverse.ravel(), members)))
    return out or everything


ARM_ROWS = (
    256  # points whose arms are found in one run of Dijkstra: a run holds this many rows of the tree's points
)


def _arms(
    tree: Any, pts: NDArray[np.float64], js: NDArray[np.intp], reach: float
) -> tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64]]:
    """The arms leaving each of the points ``js`` of a spanning tree (CSR, both directions, edges
    shorter than ``reach``) of ``pts`` that run at least ``reach`` on from it along the tree: each
    arm's point (its row in ``js``), how far it runs (up to twice ``reach``) and the vector to its
    point ``reach`` along; by point, then by the arm's first step."""
    parts = [_arms_of(tree, pts, js[s : s + ARM_ROWS], reach, s) for s in range(0, len(js), ARM_ROWS)]
    if not parts:
        return np.zeros(0, np.intp), np.zeros(0), np.zeros((0, 2))
    row, far, vector = (np.concatenate(a) for a in zip(*parts))
    return row, far, vector


def _arms_of(
    tree: Any, pts: NDArray[np.float64], js: NDArray[np.intp], reach: float, first_row: int
) -> tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64]]:
    """:func:`_arms` of up to :data:`ARM_ROWS` points (rows from ``first_row`` on), in one run."""
    m, n = len(js), len(pts)
    dist, pred = dijkstra(tree, indices=js, limit=2 * reach, return_predecessors=True)
    near = np.isfinite(dist)
    near[np.arange(m), js] = False
    r, k = np.nonzero(near)
    first = k.copy()  # each point's first step from its row's point, found by walking back
    while (back := pred[r, first] != js[r]).any():
        first[back] = pred[r[back], first[back]]
    d = dist[r, k]
    key = r * n + first
    order = np.lexsort((np.abs(d - reach), key))  # per arm, its point nearest ``reach`` along first
    starts = np.flatnonzero(np.r_[True, key[order][1:] != key[order][:-1]])
    far = np.maximum.reduceat(d[order], starts)
    row = r[order][starts]
    vector = pts[k[order][starts]] - pts[js[row]]
    long = (far >= reach) & vector.any(axis=1)
    return row[long] + first_row, far[long], vector[long]


def _junctions(
    row: NDArray[np.intp], far: NDArray[np.float64], vector: NDArray[np.float64], m: int
) -> NDArray[np.bool_]:
    """Which of ``m`` points whose arms are these (:func:`_arms`) are junctions of distinct lines:
    three or more arms headed more than :data:`ARM_ANGLE` apart, taken longest first. A line two
    tiles wide spans a ladder whose rungs are junctions, but every arm of a rung heads along the
    line."""
    apart = float(np.cos(np.radians(ARM_ANGLE)))
    out = np.zeros(m, bool)
    for j in np.flatnonzero(np.bincount(row, minlength=m) >= 3):
        mine = np.flatnonzero(row == j)
        distinct: list[NDArray[np.float64]] = []
        for v in vector[mine[np.argsort(-far[mine], kind="stable")]]:
            h = v / np.hypot(*v)
            if all(float(h @ other) < apart for other in distinct):
                distinct.append(h)
        out[j] = len(distinct) >= 3
    return out


def _corners(
    row: NDArray[np.intp], far: NDArray[np.float64], vector: NDArray[np.float64], m: int, reach: float
) -> NDArray[np.bool_]:
    """Which of ``m`` points whose arms are these (:func:`_arms`) are corners: each has two arms,
    headed less than 180° − :data:`BEND` apart and more than :data:`ARM_ANGLE` apart (as distinct
    lines), where one line may run on into another of another section. Each arm must run on away
    from the point, its point ``reach`` along at least half that far off: the rails of a line two
    tiles wide meet in hairpins of its spanning tree, whose arms double back."""
    out = np.zeros(m, bool)
    if BEND is None:
        return out
    two = np.flatnonzero(np.bincount(row, minlength=m)[row] == 2)  # arms of points with two, in pairs
    a, b, of = vector[two[0::2]], vector[two[1::2]], row[two[0::2]]
    la, lb = np.hypot(*a.T), np.hypot(*b.T)
    cos = np.einsum("ij,ij->i", a, b) / (la * lb)
    corner = (np.minimum(la, lb) >= reach / 2) & (cos > np.cos(np.radians(180.0 - BEND)))
    corner &= cos < np.cos(np.radians(ARM_ANGLE))
    out[of[corner]] = True
    return out


def _extent(pts: NDArray[np.float64]) -> float:
    return float(np.hypot(*(pts.max(axis=0) - pts.min(axis=0))))
