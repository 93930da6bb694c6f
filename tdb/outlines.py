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
    rings: list[NDArray[np.float64]] = []
    polygon_of: list[int] = []  # per ring, its polygon; a polygon's first ring is its shell
    # 4-connected outlines are valid rings; cells meeting at a corner become parts of one
    # multipolygon (a ring through its own corner is not valid in GIS)
    for geom, value in rasterio.features.shapes(north_up, mask=north_up >= 0, connectivity=4, transform=transform):
        for ring in geom["coordinates"]:
            rings.append(np.asarray(ring, float))
            polygon_of.append(len(values))
        values.append(int(value))
    parts: dict[int, list[Any]] = {}
    if rings:
        # built all at once: one shapely call per polygon costs more than the polygoniser
        ring_of = np.repeat(np.arange(len(rings)), [len(r) for r in rings])
        closed = shapely.linearrings(np.concatenate(rings), indices=ring_of)
        polygons = shapely.polygons(closed, indices=np.asarray(polygon_of))
        for value, polygon in zip(values, polygons, strict=True):
            parts.setdefault(value, []).append(polygon)
    # the parts of a label are disjoint (4-connected), touching at corners at most: no union needed
    return {k: v[0] if len(v) == 1 else shapely.multipolygons(v) for k, v in parts.items()}
