"""GeoTIFF output through rasterio (GDAL), so QGIS and GDAL read it as-is."""

from __future__ import annotations

import os

import numpy as np

from tdb.atomic import GEOTIFF, atomic_path, check_destination
from tdb.raster import Raster


def write_geotiff(
    path: str | os.PathLike[str], raster: Raster, *, nodata: float = -9999.0, tags: dict[str, str] | None = None
) -> None:
    """Write a single-band float32 GeoTIFF (deflate-compressed, tiled) with the raster's CRS and
    ``tags`` (GDAL metadata items, which QGIS shows in the layer's properties).

    Written beside the destination and moved into place.
    """
    import rasterio
    from rasterio.transform import from_origin

    p = check_destination(path, GEOTIFF, what="a GeoTIFF")
    data = np.where(np.isnan(raster.data), nodata, raster.data).astype(np.float32)
    profile = {
        "driver": "GTiff",
        "height": data.shape[0],
        "width": data.shape[1],
        "count": 1,
        "dtype": "float32",
        "nodata": nodata,
        "transform": from_origin(raster.x0, raster.y1, raster.cell, raster.cell),
        "compress": "deflate",
        "tiled": data.shape[0] >= 256 and data.shape[1] >= 256,
    }
    if raster.crs is not None:
        profile["crs"] = rasterio.crs.CRS.from_wkt(raster.crs.to_wkt())
    with atomic_path(p, errors=(rasterio.errors.RasterioError,)) as tmp:
        with rasterio.open(tmp, "w", **profile) as dst:
            dst.write(data, 1)
            if tags:
                dst.update_tags(**tags)
