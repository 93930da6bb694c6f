"""Triangulated surfaces on numpy arrays: the TIN, point location, barycentrics, normals."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import Delaunay, QhullError

from tdb.bbox import column_range
from tdb.errors import DegenerateInputError
from tdb.threads import one_blas_thread


@dataclass(frozen=True)
class Tin:
    """A Delaunay triangulation of plan positions, built on coordinates less ``origin``.

    Projected coordinates of the order of 10⁶ m cost Qhull precision: its point
    location walks then fail and fall back to searching every triangle. So the
    triangulation is built relative to the points' lower-left corner, and every
    function here that takes positions subtracts ``origin`` first.
    """

    qhull: Delaunay
    origin: NDArray[np.float64]
    transform: NDArray[np.float64] = field(repr=False)

    @property
    def simplices(self) -> NDArray[np.intp]:
        """(K, 3) vertex indices of each triangle."""
        return np.asarray(self.qhull.simplices, np.intp)

    @property
    def vertex_neighbor_vertices(self) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
        """Qhull's (indptr, indices) of each vertex's neighbours."""
        indptr, indices = self.qhull.vertex_neighbor_vertices
        return indptr, indices


def triangulate(xy: NDArray[np.float64]) -> Tin:
    """Delaunay triangulation of plan positions, with a clear error on degenerate input.

    Raises
    ------
    DegenerateInputError
        For fewer than three points, or points on one line.
    """
    xy = np.asarray(xy, np.float64)
    origin = np.floor(column_range(xy)[0]) if len(xy) else np.zeros(2)
    local = xy - origin
    try:
        tri = Delaunay(local)
    except (QhullError, ValueError) as exc:
        raise DegenerateInputError(f"cannot triangulate {len(xy)} points: {str(exc).splitlines()[0]}") from None
    return Tin(tri, origin, transforms(local, np.asarray(tri.simplices, np.intp)))


SNAP = 1e-4  # m: positions closer than this are one vertex (the lower kept)
# Points handed to startinpy at a time: the same mesh as in one call (the same order of
# insertion), without its copy of the whole input beside the growing mesh at the peak.
INSERT_BATCH = 100_000


def delaunay_mesh(xyz: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """Vertices (M, 3) and triangles (K, 3, indices into the vertices) of the Delaunay
    triangulation of ``xyz``'s plan positions; of positions within ``SNAP`` of each other the
    lowest is kept.

    Built by startinpy's incremental triangulation, the points inserted along a Z-order curve
    (each insertion's walk starts next to the last): for a mesh alone (no point location) it is
    several times faster than Qhull, which lifts the points onto a paraboloid and builds a 3-D hull.

    Raises
    ------
    DegenerateInputError
        For fewer than three points, or points on one line.
    """
    import startinpy

    xyz = np.asarray(xyz, np.float64)
    if len(xyz) < 3:
        raise DegenerateInputError(f"cannot triangulate {len(xyz)} points")
    origin = np.r_[np.floor(column_range(xyz[:, :2])[0]), 0.0]
    local = (xyz - origin)[morton_order(xyz[:, :2])]
    dt = startinpy.DT()
    dt.snap_tolerance = SNAP
    dt.duplicates_handling = "Lowest"
    for s in range(0, len(local), INSERT_BATCH):
        dt.insert(local[s : s + INSERT_BATCH], insertionstrategy="AsIs")
    faces = np.asarray(dt.triangles)  # a fresh array, its indices unsigned
    faces = faces.view(np.intp) if faces.dtype.itemsize == np.dtype(np.intp).itemsize else faces.astype(np.intp)
    faces -= 1  # startinpy's vertex 0 is the one at infinity
    if len(faces) == 0:
        raise DegenerateInputError(f"cannot triangulate {len(xyz)} points: they lie on one line")
    # Where no position was merged the vertices are the inserted points, in their order;
    # reading them back from startinpy costs as much as a tenth of the insertion.
    merged = dt.number_of_vertices() != len(local)
    return (np.asarray(dt.points, np.float64)[1:] if merged else local) + origin, faces


def transforms(xy: NDArray[np.float64], simplices: NDArray[np.intp]) -> NDArray[np.float64]:
    """Barycentric transforms (K, 3, 2) of triangles, in :class:`scipy.spatial.Delaunay`'s layout:
    ``T = t[:, :2]`` and ``r = t[:, 2]`` give the first two barycentrics as ``T @ (p - r)``.

    Worked out here in closed form, because scipy's lazy ``Delaunay.transform`` makes one small
    LAPACK call per triangle, and multi-threaded BLAS spends far longer on each than the sum.
    Degenerate triangles get NaN, as scipy gives them.
    """
    p = xy[simplices]  # (K, 3, 2)
    r = p[:, 2, :]
    a, c = p[:, 0, 0] - r[:, 0], p[:, 1, 0] - r[:, 0]
    b, d = p[:, 0, 1] - r[:, 1], p[:, 1, 1] - r[:, 1]
    det = a * d - b * c
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(det != 0, 1.0 / det, np.nan)
    out = np.empty((len(simplices), 3, 2))
    out[:, 0, 0], out[:, 0, 1] = d * inv, -c * inv
    out[:, 1, 0], out[:, 1, 1] = -b * inv, a * inv
    out[:, 2, :] = r
    return out


def morton_order(xy: NDArray[np.float64]) -> NDArray[np.intp]:
    """An ordering of points along a Z-order curve (spatially coherent)."""
    lo, hi = column_range(xy)
    span = max(float((hi - lo).max()), 1e-9)
    q = ((xy - lo) / span * 65535).astype(np.uint64)
    return np.argsort(_spread_bits(q[:, 0]) | (_spread_bits(q[:, 1]) << np.uint64(1)), kind="stable")


def _spread_bits(v: NDArray[np.uint64]) -> NDArray[np.uint64]:
    """The 16 low bits of each value moved to the even bits (bit b to bit 2b): five shifts and
    masks, where a loop over the bits takes sixteen."""
    v = v & np.uint64(0xFFFF)
    for shift, mask in ((8, 0x00FF00FF), (4, 0x0F0F0F0F), (2, 0x33333333), (1, 0x55555555)):
        v = (v | (v << np.uint64(shift))) & np.uint64(mask)
    return v


def locate(tin: Tin, xy: NDArray[np.float64]) -> NDArray[np.intp]:
    """Triangle of ``tin`` holding each plan position (−1 outside).

    Qhull's walk starts where the last query ended, so the positions are asked in
    Z-order: spatially ordered queries take a few steps each instead of crossing the mesh.
    """
    return locate_in(tin.qhull, np.asarray(xy, np.float64) - tin.origin)


def locate_in(tri: Delaunay, xy: NDArray[np.float64]) -> NDArray[np.intp]:
    """:func:`locate` on a bare Qhull triangulation, with positions in its own coordinates."""
    if len(xy) == 0:
        return np.empty(0, np.intp)
    order = morton_order(xy)
    out = np.empty(len(xy), np.intp)
    with one_blas_thread():
        out[order] = tri.find_simplex(xy[order])
    return out


class Transformed(Protocol):
    """A triangulation with barycentric transforms and an origin: a :class:`Tin` or a ground TIN."""

    @property
    def origin(self) -> NDArray[np.float64]: ...

    @property
    def transform(self) -> NDArray[np.float64]: ...


def barycentric(tin: Transformed, simplex: NDArray[np.intp], xy: NDArray[np.float64]) -> NDArray[np.float64]:
    """Barycentric coordinates (M, 3) of ``xy`` in the given triangles of ``tin``."""
    t = tin.transform[simplex]
    b = np.einsum("ijk,ik->ij", t[:, :2, :], np.asarray(xy, np.float64) - tin.origin - t[:, 2, :])
    return np.column_stack([b, 1.0 - b.sum(axis=1)])


def surface_height(
    tin: Tin, z: NDArray[np.float64], xy: NDArray[np.float64], simplex: NDArray[np.intp] | None = None
) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """Height of the TIN (vertex heights ``z``) at ``xy``; NaN outside the hull. Returns (height, simplex)."""
    if simplex is None:
        simplex = locate(tin, xy)
    out = np.full(len(xy), np.nan)
    inside = simplex >= 0
    if inside.any():
        lam = barycentric(tin, simplex[inside], xy[inside])
        out[inside] = (lam * z[tin.simplices[simplex[inside]]]).sum(axis=1)
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
