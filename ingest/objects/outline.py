"""Outlines of labelled raster segments as polygons."""

from __future__ import annotations

from typing import Any

import numpy as np
import rasterio.features
import shapely
from numpy.typing import NDArray
from rasterio.transform import from_origin

from ingest.ground.grids import Grid


def outlines(labels: NDArray[np.intp], grid: Grid) -> dict[int, Any]:
    """Polygon of each label ≥ 0 (rows south to north on ``grid``), as a shapely geometry."""
    rows = labels.shape[0]
    transform = from_origin(grid.x0, grid.y0 + rows * grid.cell, grid.cell, grid.cell)
    north_up = labels[::-1].astype(np.int32)
    parts: dict[int, list[Any]] = {}
    for geom, value in rasterio.features.shapes(north_up, mask=north_up >= 0, connectivity=8, transform=transform):
        parts.setdefault(int(value), []).append(shapely.geometry.shape(geom))
    return {k: v[0] if len(v) == 1 else shapely.MultiPolygon(v) for k, v in parts.items()}
