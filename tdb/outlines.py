"""Outlines of labelled raster segments as polygons (GDAL's polygoniser, through rasterio)."""

from __future__ import annotations

from typing import Any

import numpy as np
import rasterio.features
import shapely
from affine import Affine
from numpy.typing import NDArray


def outlines(labels: NDArray[np.integer], *, x0: float, y0: float, cell: float) -> dict[int, Any]:
    """Polygon of each label ≥ 0 of a raster whose rows run south to north from the lower-left
    corner (``x0``, ``y0``), cells ``cell`` metres square, as a shapely geometry."""
    rows = labels.shape[0]
    transform = Affine(cell, 0.0, x0, 0.0, -cell, y0 + rows * cell)
    north_up = labels[::-1].astype(np.int32)
    values: list[int] = []
    shells: list[NDArray[np.float64]] = []
    holed: dict[int, list[Any]] = {}
    # 4-connected outlines are valid rings; cells meeting at a corner become parts of one
    # multipolygon (a ring through its own corner is not valid in GIS)
    for geom, value in rasterio.features.shapes(north_up, mask=north_up >= 0, connectivity=4, transform=transform):
        rings = geom["coordinates"]
        if len(rings) == 1:  # most: built below all at once, not one by one
            values.append(int(value))
            shells.append(np.asarray(rings[0], float))
        else:
            holed.setdefault(int(value), []).append(shapely.geometry.shape(geom))
    parts: dict[int, list[Any]] = {}
    if shells:
        ring_of = np.repeat(np.arange(len(shells)), [len(s) for s in shells])
        polygons = shapely.polygons(shapely.linearrings(np.concatenate(shells), indices=ring_of))
        for value, polygon in zip(values, polygons, strict=True):
            parts.setdefault(value, []).append(polygon)
    for value, polys in holed.items():
        parts.setdefault(value, []).extend(polys)
    # the parts of a label are disjoint (4-connected), touching at corners at most: no union needed
    return {k: v[0] if len(v) == 1 else shapely.multipolygons(v) for k, v in parts.items()}
