"""Areas of interest: the stored points triangulated, as a mesh or a surface grid."""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from tdb.atomic import atomic_path
from tdb.database import Area, Database
from tdb.errors import InputError
from tdb.raster import Raster
from tdb.rasterise import PostGrid
from tdb.surface import KeptMesh, kept_mesh, mesh_grid


def area_surface(
    area: Area,
    *,
    cell: float | None = None,
    crs: Any = None,
    bbox: tuple[float, float, float, float] | None = None,
    mesh: KeptMesh | None = None,
) -> Raster:
    """The surface rebuilt from the area's points (linear TIN, corner-only tiles split as their
    categories imply: :mod:`tdb.surface`), on a grid of ``cell`` m (default: the level's sub-grid
    spacing, level / 4) over ``bbox`` (default: the area's own; a smaller one keeps the grid's
    edge cells inside the triangulation). ``mesh``: the area's, where the caller has it already
    (:func:`area_mesh`)."""
    mesh = mesh or area_mesh(area)
    cell = cell or area.level / 4
    x0, y0, x1, y1 = bbox or area.bbox
    xs = np.arange(np.ceil(x0 / cell) * cell, x1 + 1e-9, cell)
    ys = np.arange(np.floor(y1 / cell) * cell, y0 - 1e-9, -cell)
    z = mesh_grid(mesh, PostGrid(float(xs[0]), float(ys[0]), cell, len(ys), len(xs)))
    return Raster(z, float(xs[0] - cell / 2), float(ys[0] + cell / 2), cell, crs)


def area_mesh(area: Area) -> KeptMesh:
    """The mesh of the area's points and tiles; an :class:`InputError` for fewer than three points."""
    if len(area.x) < 3:
        raise InputError(f"the area holds {len(area.x)} points; nothing to triangulate")
    return kept_mesh(area.x, area.y, area.z, xg=area.xg, yg=area.yg, code=area.code, level=area.level)


def overview_surface(
    db: Database,
    version: str,
    bbox: tuple[float, float, float, float],
    *,
    level: int = 2,
    max_cells: int = 4_000_000,
) -> Raster:
    """The surface over ``bbox`` for a picture: the level's kept points triangulated, on cells of
    level / 4 m, or coarser where that would exceed ``max_cells``."""
    x0, y0, x1, y1 = bbox
    cell = max(level / 4, float(np.sqrt((x1 - x0) * (y1 - y0) / max_cells)))
    grown = (x0 - level, y0 - level, x1 + level, y1 + level)
    return area_surface(db.aoi(grown, level=level, version=version), cell=cell, crs=db.crs(version), bbox=bbox)


def write_ply(path: str | os.PathLike[str], area: Area, *, mesh: KeptMesh | None = None) -> None:
    """The area's points as a triangulated mesh in ASCII PLY (coordinates relative to the bbox corner
    would lose georeference, so they are written as they are, in metres); ``mesh`` as for
    :func:`area_surface`."""
    faces = (mesh or area_mesh(area)).faces
    xyz = np.column_stack([area.x, area.y, area.z])
    header = (
        "ply\nformat ascii 1.0\ncomment tdb area of interest\n"
        f"element vertex {len(xyz)}\nproperty double x\nproperty double y\nproperty double z\n"
        f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    with atomic_path(path) as tmp, tmp.open("w") as fh:
        fh.write(header)
        np.savetxt(fh, xyz, fmt="%.3f")
        np.savetxt(fh, np.column_stack([np.full(len(faces), 3), faces]), fmt="%d")
