"""The dense ground model: a regular grid interpolated from the ground points.

Linear interpolation on the Delaunay TIN of the ground points, evaluated at
cell centres by scan conversion (:mod:`tdb.rasterise`); cells outside the points' convex hull, or under a TIN facet
longer than ``max_edge``, are no-data rather than guesses.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tdb.bbox import column_range
from tdb.errors import InputError
from tdb.raster import MAX_CELLS, Raster
from tdb.rasterise import rasterise
from tdb.tin import delaunay_mesh

DEFAULT_RESOLUTION = 0.5


def dense_model(
    ground_xyz: NDArray[np.float64],
    *,
    resolution: float = DEFAULT_RESOLUTION,
    bounds: tuple[float, float, float, float] | None = None,
    max_edge: float | None = 50.0,
    crs: Any = None,
) -> Raster:
    """Grid of ground heights at ``resolution`` m over ``bounds`` (default: the points' extent).

    Parameters
    ----------
    ground_xyz : (N, 3) ground points in metres.
    resolution : cell size in metres.
    bounds : (xmin, ymin, xmax, ymax); snapped outward to whole cells.
    max_edge : facets with an edge longer than this (m) are no-data (large gaps); None keeps all.
    crs : stored with the raster.
    """
    if resolution <= 0:
        raise InputError(f"resolution must be positive, got {resolution}")
    xyz = np.asarray(ground_xyz, float)
    if bounds is None:
        lo, hi = column_range(xyz[:, :2])
        bounds = (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))
    xyz, faces = delaunay_mesh(xyz)
    # Posts (cell centres) sit on whole multiples of the resolution, so the 2 m tile
    # sub-grid nodes are posts and grids of two surveys line up exactly.
    first_x = np.floor(bounds[0] / resolution) * resolution
    first_y = np.floor(bounds[1] / resolution) * resolution
    cols = int(np.ceil((bounds[2] - first_x) / resolution)) + 1
    rows = int(np.ceil((bounds[3] - first_y) / resolution)) + 1
    x0 = first_x - resolution / 2
    y0 = first_y - resolution / 2
    if rows * cols > MAX_CELLS:
        raise InputError(
            f"a {resolution} m grid over this extent needs {rows * cols:,} cells; use a coarser resolution"
        )
    raster = Raster(np.full((rows, cols), np.nan), float(x0), float(y0 + rows * resolution), resolution, crs)
    # no guess across a big gap
    return replace(raster, data=rasterise(xyz[:, :2], xyz[:, 2], faces, raster.posts(), max_edge=max_edge))
