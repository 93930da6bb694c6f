"""The DEM of difference between two versions, from the surfaces change detection compares.

``after − before`` at every node of the level's sub-grid (0.5 m at level 2). Each
version's surface is rebuilt tile by tile from the points it keeps (the tile's corners,
its feature's nodes and those the reduction added, bridged by lines along the tile's
rows and columns, as in :mod:`queries.changes`), so a node's value depends on its own
tile alone: the same whatever box it is read in. Nodes of tiles that either version
lacks, or holds as no data, stay no data rather than an interpolation across the gap.
"""

from __future__ import annotations

import numpy as np

from queries.coregister import Shift
from queries.grids import Box, surface_grids
from tdb.database import Database
from tdb.raster import MAX_CELLS, Raster


def difference_of_surfaces(  # noqa: PLR0913 (the two versions, where, and how fine)
    db: Database,
    before: str,
    after: str,
    *,
    level: int = 2,
    bbox: Box | None = None,
    max_cells: int = MAX_CELLS // 10,
    fit: bool = False,
    shift: Shift | None = None,
) -> Raster:
    """``after − before`` (m) at the sub-grid nodes (spacing level / 4, one cell centred on each)
    of the tiles both versions hold inside ``bbox`` (default: all of them), in ``after``'s CRS.
    With ``fit`` a grid over ``max_cells`` keeps every k-th node instead of raising. With a
    ``shift`` (:mod:`queries.coregister`), ``after`` is co-registered onto ``before`` first.

    Raises
    ------
    InputError
        If the versions share no tiles there, or the grid would exceed ``max_cells``.
    """
    first, second = surface_grids(db, before, after, level=level, bbox=bbox, max_cells=max_cells, fit=fit)
    if shift is not None and shift.applied:
        second = shift.apply(second)
    return Raster(second.data - first.data, first.x0, first.y1, first.cell, db.crs(after))


def describe(dod: Raster, *, lod: float) -> dict[str, float]:
    """Shares of a difference grid's cells lowered and raised beyond ``lod``."""
    v = dod.data[np.isfinite(dod.data)]
    n = max(len(v), 1)
    return {"lowered_share": float((v <= -lod).sum() / n), "raised_share": float((v >= lod).sum() / n)}
