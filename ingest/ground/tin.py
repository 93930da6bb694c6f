"""Triangulated surfaces on numpy arrays: barycentrics, heights above facets, normals."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import Delaunay, QhullError

from tdb.errors import DegenerateInputError


def triangulate(xy: NDArray[np.float64]) -> Delaunay:
    """Delaunay triangulation of plan positions, with a clear error on degenerate input.

    The triangulation is built on coordinates relative to the points' lower-left
    corner (kept as ``tri.origin``; :func:`locate` and :func:`barycentric` apply
    it). Projected coordinates of the order of 10⁶ m cost Qhull precision: its
    point location walks then fail and fall back to searching every triangle,
    which made a 1 M point DTM take 90 s instead of 10.
    """
    xy = np.asarray(xy, np.float64)
    origin = np.floor(xy.min(axis=0)) if len(xy) else np.zeros(2)
    try:
        tri = Delaunay(xy - origin)
    except (QhullError, ValueError) as exc:
        raise DegenerateInputError(f"cannot triangulate {len(xy)} points: {str(exc).splitlines()[0]}") from None
    tri.origin = origin
    return tri


def _local(tri: Delaunay, xy: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.asarray(xy, np.float64) - getattr(tri, "origin", 0.0)


def morton_order(xy: NDArray[np.float64]) -> NDArray[np.intp]:
    """An ordering of points along a Z-order curve (spatially coherent)."""
    lo = xy.min(axis=0)
    span = max(float((xy.max(axis=0) - lo).max()), 1e-9)
    q = ((xy - lo) / span * 65535).astype(np.uint64)
    key = np.zeros(len(xy), np.uint64)
    for bit in range(16):
        key |= ((q[:, 0] >> np.uint64(bit)) & np.uint64(1)) << np.uint64(2 * bit)
        key |= ((q[:, 1] >> np.uint64(bit)) & np.uint64(1)) << np.uint64(2 * bit + 1)
    return np.argsort(key, kind="stable")


def locate(tri: Delaunay, xy: NDArray[np.float64]) -> NDArray[np.intp]:
    """``tri.find_simplex`` in Z-order: its walk starts where the last query ended,
    so spatially ordered queries take a few steps each instead of crossing the mesh."""
    if len(xy) == 0:
        return np.empty(0, np.intp)
    xy = _local(tri, xy)
    order = morton_order(xy)
    out = np.empty(len(xy), np.intp)
    out[order] = tri.find_simplex(xy[order])
    return out


def barycentric(tri: Delaunay, simplex: NDArray[np.intp], xy: NDArray[np.float64]) -> NDArray[np.float64]:
    """Barycentric coordinates (M, 3) of ``xy`` in the given simplices of ``tri`` (a ``Delaunay`` or
    anything with its ``transform`` and ``origin``, such as a ``GroundTin``)."""
    t = tri.transform[simplex]
    b = np.einsum("ijk,ik->ij", t[:, :2, :], _local(tri, xy) - t[:, 2, :])
    return np.column_stack([b, 1.0 - b.sum(axis=1)])


def surface_height(
    tri: Delaunay, z: NDArray[np.float64], xy: NDArray[np.float64], simplex: NDArray[np.intp] | None = None
) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """Height of the TIN (vertex heights ``z``) at ``xy``; NaN outside the hull. Returns (height, simplex)."""
    if simplex is None:
        simplex = locate(tri, xy)
    out = np.full(len(xy), np.nan)
    inside = simplex >= 0
    if inside.any():
        lam = barycentric(tri, simplex[inside], xy[inside])
        out[inside] = (lam * z[tri.simplices[simplex[inside]]]).sum(axis=1)
    return out, simplex


def unit_normals(p0: NDArray[np.float64], p1: NDArray[np.float64], p2: NDArray[np.float64]) -> NDArray[np.float64]:
    """Upward unit normals (M, 3) of triangles given by vertex arrays (M, 3)."""
    n = np.cross(p1 - p0, p2 - p0)
    n *= np.sign(n[:, 2:3] + (n[:, 2:3] == 0))
    length = np.linalg.norm(n, axis=1, keepdims=True)
    return n / np.where(length == 0, 1.0, length)


def angle_between(n1: NDArray[np.float64], n2: NDArray[np.float64]) -> NDArray[np.float64]:
    """Angle in degrees between unit normals, row by row."""
    return np.degrees(np.arccos(np.clip((n1 * n2).sum(axis=1), -1.0, 1.0)))


def group_starts(keys: NDArray[np.intp]) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.intp]]:
    """For sorted ``keys``: the unique keys, where each group starts, and its size."""
    if len(keys) == 0:
        empty = np.empty(0, np.intp)
        return empty, empty, empty
    starts = np.flatnonzero(np.r_[True, keys[1:] != keys[:-1]])
    sizes = np.diff(np.r_[starts, len(keys)])
    return keys[starts], starts, sizes


def cross_pairs(a_group: NDArray[np.intp], b_group: NDArray[np.intp]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """All pairs (i, j) with a_group[i] == b_group[j], as index arrays into a and b."""
    ao = np.argsort(a_group, kind="stable")
    bo = np.argsort(b_group, kind="stable")
    ak, astart, asize = group_starts(a_group[ao])
    bk, bstart, bsize = group_starts(b_group[bo])
    common, ia, ib = np.intersect1d(ak, bk, assume_unique=True, return_indices=True)
    na, nb = asize[ia], bsize[ib]
    per = na * nb
    total = int(per.sum())
    if total == 0:
        empty = np.empty(0, np.intp)
        return empty, empty
    grp = np.repeat(np.arange(len(common)), per)
    offset = np.arange(total) - np.repeat(np.cumsum(per) - per, per)
    i = ao[astart[ia][grp] + offset // nb[grp]]
    j = bo[bstart[ib][grp] + offset % nb[grp]]
    return i, j
