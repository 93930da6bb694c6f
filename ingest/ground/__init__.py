"""Ground filters: Sohn–Dowman, Elmqvist's active contour, and the default."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from ingest.ground.auto import AutoParams, auto_ground
from ingest.ground.contour import ContourParams, active_contour
from ingest.ground.outliers import deep_pits, low_outliers
from ingest.ground.sohn import SohnParams, sohn_dowman
from ingest.ground.tiling import available_cores, by_tiles
from tdb.cloud import PointCloud, check_spread, from_arrays
from tdb.options import GroundMethod, parse

__all__ = ["AutoParams", "ContourParams", "SohnParams", "classify_ground", "deep_pits", "low_outliers"]


def classify_ground(
    points: PointCloud | NDArray[np.float64],
    *,
    method: str | GroundMethod = "auto",
    progress: Callable[[int, int], None] | None = None,
) -> NDArray[np.bool_]:
    """Ground mask of a point cloud (coordinates in metres).

    Parameters
    ----------
    points : a :class:`PointCloud` or an (N, 3) array.
    method : ``auto`` (default filter), ``sohn`` (Sohn & Dowman 2002) or
        ``contour`` (Elmqvist active contour). See :class:`GroundMethod`.
    progress : called with (tiles done, tiles) as Sohn–Dowman's tiles finish (the other
        filters run whole: once, with (1, 1), at the end).

    Raises
    ------
    DegenerateInputError
        For fewer than three points, or points spanning no area.
    """
    m = parse(GroundMethod, method)
    cloud = points if isinstance(points, PointCloud) else from_arrays(*np.asarray(points, float).T, validate=False)
    check_spread(cloud)
    xyz = cloud.xyz
    if m is GroundMethod.AUTO:
        ground = auto_ground(xyz)
        if progress:
            progress(1, 1)
        return ground
    # The papers have no outlier step; both use the default filter's (see docs/ground.md):
    # Sohn's downward step would make a 25 m deep multipath cluster a TIN vertex (samp41).
    out = low_outliers(xyz) | deep_pits(xyz)
    ground = np.zeros(len(xyz), bool)
    keep = np.flatnonzero(~out)
    if m is GroundMethod.SOHN:
        ground[keep] = by_tiles(xyz[keep], sohn_dowman, workers=available_cores(), progress=progress)
    else:
        ground[keep] = active_contour(xyz[keep])
        if progress:
            progress(1, 1)
    return ground
