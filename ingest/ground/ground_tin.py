"""A ground TIN that takes new vertices by re-triangulating only where they land.

Sohn–Dowman's upward step adds a few hundred points to a TIN of tens of thousands
per pass, and rebuilding the whole Delaunay triangulation with Qhull each pass cost
a third of the filter. Adding points only changes the triangles whose circumcircle
holds one of them (the cavity); every other triangle stays Delaunay. So the cavity's
corners and the new points are triangulated alone, and the new triangles inside
the cavity replace the old ones. The result is the Delaunay triangulation of all
vertices, as a rebuild gives it (up to the choice among co-circular points). Where
a check of the result fails (co-circular points on the cavity's edge, duplicate
positions) or the cavity is most of the TIN, it is rebuilt whole.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import Delaunay, QhullError, cKDTree

from tdb.tin import Tin, locate, locate_in, transforms, triangulate

LOCAL_SHARE = 0.3  # rebuild whole where the cavity holds more of the triangles than this


@dataclass(frozen=True)
class GroundTin:
    """Delaunay TIN of ``points`` (V, 3), triangulated in plan on coordinates less ``origin``.

    ``simplices`` and ``transform`` have the layout of :class:`scipy.spatial.Delaunay`'s, so
    :func:`tdb.tin.barycentric` takes a ``GroundTin`` as it takes a ``Delaunay``.
    """

    points: NDArray[np.float64]
    origin: NDArray[np.float64]
    simplices: NDArray[np.intp]
    transform: NDArray[np.float64]
    centre: NDArray[np.float64]  # (K, 2) circumcentres, local coordinates
    radius2: NDArray[np.float64]  # (K,) squared circumradii
    tin: Tin | None = None  # the whole triangulation, where it was just built

    @classmethod
    def build(cls, points: NDArray[np.float64]) -> GroundTin:
        points = np.asarray(points, np.float64)
        tin = triangulate(points[:, :2])
        simplices = tin.simplices
        centre, radius2 = _circles(points[:, :2] - tin.origin, simplices)
        return cls(points, tin.origin, simplices, tin.transform, centre, radius2, tin)

    def locate(self, xy: NDArray[np.float64]) -> NDArray[np.intp]:
        """Triangle of each plan position (−1 outside); right after :meth:`build` only."""
        if self.tin is None:
            raise RuntimeError("locate needs a freshly built TIN")
        return locate(self.tin, xy)

    def insert(
        self,
        new: NDArray[np.float64],
        new_simplex: NDArray[np.intp],
        xy: NDArray[np.float64],
        simplex: NDArray[np.intp],
    ) -> tuple[GroundTin, NDArray[np.intp]]:
        """The TIN with the points ``new`` (P, 3) added, and the triangle of each plan position
        ``xy`` in it, given its triangle ``simplex`` now (``new_simplex``: the triangles the new
        points lie in now)."""
        if len(new) == 0:
            return self, simplex
        local = _local_insert(self, np.asarray(new, np.float64), new_simplex, xy, simplex)
        if local is not None:
            return local
        tin = GroundTin.build(np.vstack([self.points, new]))
        return tin, tin.locate(xy)


def _circles(xy: NDArray[np.float64], simplices: NDArray[np.intp]) -> tuple[NDArray[np.float64], ...]:
    """Circumcentres (K, 2) and squared circumradii (K,) of triangles (inf for degenerate ones)."""
    a, b, c = (xy[simplices[:, k]] for k in range(3))
    ba, ca = b - a, c - a
    d = 2.0 * (ba[:, 0] * ca[:, 1] - ba[:, 1] * ca[:, 0])
    nb, nc = (ba**2).sum(axis=1), (ca**2).sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ux = (ca[:, 1] * nb - ba[:, 1] * nc) / d
        uy = (ba[:, 0] * nc - ca[:, 0] * nb) / d
    centre = a + np.column_stack([ux, uy])
    radius2 = ux**2 + uy**2
    bad = ~np.isfinite(radius2)
    centre[bad], radius2[bad] = 0.0, np.inf
    return centre, radius2


def _keys(simplices: NDArray[np.intp], n: int) -> NDArray[np.int64]:
    """One integer per triangle, the same whatever the order of its vertices (ids below ``n``)."""
    s = np.sort(simplices, axis=1).astype(np.int64)
    return (s[:, 0] * n + s[:, 1]) * n + s[:, 2]


def _local_insert(
    tin: GroundTin,
    new: NDArray[np.float64],
    new_simplex: NDArray[np.intp],
    xy: NDArray[np.float64],
    simplex: NDArray[np.intp],
) -> tuple[GroundTin, NDArray[np.intp]] | None:
    """:meth:`GroundTin.insert` by re-triangulating the cavity; None where that cannot be trusted."""
    k, v0 = len(tin.simplices), len(tin.points)
    new_xy = new[:, :2] - tin.origin
    # The cavity: triangles whose circumcircle holds a new point (with a margin: a triangle taken
    # in that did not need to be is triangulated again the same way).
    d, _ = cKDTree(new_xy).query(tin.centre, k=1)
    cavity = d * d <= tin.radius2 * (1 + 1e-9) + 1e-12
    cavity[new_simplex] = True
    bad = np.flatnonzero(cavity)
    if len(bad) > LOCAL_SHARE * k:
        return None
    corners = np.unique(tin.simplices[bad])
    # A new point on the spot of a vertex or of another new point (another return of the same
    # pulse) is left out of the triangulation, as a rebuild leaves all but one out.
    all_xy = np.vstack([tin.points[corners, :2] - tin.origin, new_xy])
    _, first = np.unique(all_xy, axis=0, return_index=True)
    added = np.sort(first[first >= len(corners)])
    ids = np.concatenate([corners, v0 - len(corners) + added])
    all_xy = all_xy[np.concatenate([np.arange(len(corners)), added])]
    try:
        before = Delaunay(all_xy[: len(corners)])
        after = Delaunay(all_xy)
    except QhullError:
        return None
    n = v0 + len(new)
    # The cavity's triangles, as the corners alone triangulate them: the same ones, or a tie.
    in_cavity = np.isin(_keys(corners[before.simplices], n), _keys(tin.simplices[bad], n))
    if in_cavity.sum() != len(bad):
        return None
    centroid = all_xy[after.simplices].mean(axis=1)
    s = locate_in(before, centroid)
    inside = (s >= 0) & in_cavity[np.maximum(s, 0)]
    # Each point added inside a triangulated polygon adds two triangles.
    if len(after.coplanar) or inside.sum() != len(bad) + 2 * len(added):
        return None
    fresh = ids[after.simplices[inside]]
    keep = np.ones(k, bool)
    keep[bad] = False
    row = np.full(k, -1, np.intp)
    row[keep] = np.arange(int(keep.sum()))
    points = np.vstack([tin.points, new])
    centre, radius2 = _circles(all_xy, after.simplices[inside])  # the cavity's own coordinates
    out = GroundTin(
        points,
        tin.origin,
        np.vstack([tin.simplices[keep], fresh]),
        np.concatenate([tin.transform[keep], transforms(all_xy, after.simplices[inside])]),
        np.vstack([tin.centre[keep], centre]),
        np.concatenate([tin.radius2[keep], radius2]),
    )
    # Positions in the cavity are found in its new triangles; the others keep theirs, renumbered.
    moved = cavity[simplex]
    out_simplex = row[simplex]
    if moved.any():
        at = xy[moved] - tin.origin
        local = locate_in(after, at)
        remap = np.full(len(after.simplices), -1, np.intp)
        remap[np.flatnonzero(inside)] = len(keep) - len(bad) + np.arange(int(inside.sum()))
        found = np.where(local >= 0, remap[np.maximum(local, 0)], -1)
        lost = np.flatnonzero(found < 0)
        if len(lost):  # on the cavity's edge (on one of its corners, as another return of it)
            found[lost] = _nearest_triangle(after, np.flatnonzero(inside), at[lost], remap)
            if (found[lost] < 0).any():
                return None
        out_simplex[moved] = found
    return out, out_simplex


def _nearest_triangle(
    tri: Delaunay, among: NDArray[np.intp], xy: NDArray[np.float64], remap: NDArray[np.intp]
) -> NDArray[np.intp]:
    """For each position, the triangle of ``tri`` among ``among`` that holds it (on its edge, up to
    round-off), as ``remap`` numbers it; −1 where none does (or too many positions to search)."""
    if len(xy) * len(among) > 5_000_000:
        return np.full(len(xy), -1, np.intp)
    t = transforms(tri.points, tri.simplices[among])  # (F, 3, 2)
    b = np.einsum("fij,pfj->pfi", t[:, :2, :], xy[:, None, :] - t[None, :, 2, :])
    least = np.minimum(b.min(axis=2), 1.0 - b.sum(axis=2))  # (P, F): the smallest barycentric
    best = least.argmax(axis=1)
    ok = least[np.arange(len(xy)), best] > -1e-9
    return np.where(ok, remap[among[best]], -1)
