"""GeoJSON features and collections: the one place tdb builds them.

Results are plain GeoJSON dicts (what ``json.dumps`` writes and QGIS reads); a collection names
its CRS as an OGC URN where the CRS has an EPSG code (the 2008 convention GDAL still reads).
"""

from __future__ import annotations

from typing import Any

import shapely


def feature(geometry: shapely.Geometry, properties: dict[str, Any]) -> dict[str, Any]:
    """A GeoJSON Feature of a shapely geometry and its properties."""
    return {"type": "Feature", "geometry": shapely.geometry.mapping(geometry), "properties": properties}


def feature_collection(
    features: list[dict[str, Any]], crs: Any, *, members: dict[str, Any] | None = None
) -> dict[str, Any]:
    """A FeatureCollection of ``features`` in ``crs`` (a pyproj CRS, anything it reads, or None),
    with foreign ``members`` (such as a diff's ``coregistration``) beside them."""
    from tdb.crs import as_crs

    doc: dict[str, Any] = {"type": "FeatureCollection", **(members or {}), "features": features}
    parsed = as_crs(crs)
    code = parsed.to_epsg() if parsed is not None else None
    if code:
        doc["crs"] = {"type": "name", "properties": {"name": f"urn:ogc:def:crs:EPSG::{code}"}}
    return doc
