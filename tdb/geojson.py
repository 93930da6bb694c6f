"""GeoJSON features and collections: the one place tdb builds them.

Results are plain GeoJSON dicts (what ``json.dumps`` writes and QGIS reads); a collection names
its CRS as an OGC URN where the CRS has an EPSG code (the 2008 convention GDAL still reads), or
its horizontal part's where it is compound (UTM with a geoid's heights), so that no reader takes
metres for degrees. A value that is not a number (NaN, an infinity) is written as null: JSON has
no NaN.
"""

from __future__ import annotations

import math
from typing import Any

import shapely


def feature(geometry: shapely.Geometry, properties: dict[str, Any]) -> dict[str, Any]:
    """A GeoJSON Feature of a shapely geometry and its properties (non-finite numbers as None)."""
    return {"type": "Feature", "geometry": shapely.geometry.mapping(geometry), "properties": finite(properties)}


def finite(value: Any) -> Any:
    """``value`` with every float that is not finite, however deep in dicts and lists, as None."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [finite(v) for v in value]
    return value


def feature_collection(
    features: list[dict[str, Any]], crs: Any, *, members: dict[str, Any] | None = None
) -> dict[str, Any]:
    """A FeatureCollection of ``features`` in ``crs`` (a pyproj CRS, anything it reads, or None),
    with foreign ``members`` (such as a diff's ``coregistration``) beside them."""
    from tdb.crs import as_crs, horizontal_part

    doc: dict[str, Any] = {"type": "FeatureCollection", **finite(members or {}), "features": features}
    parsed = as_crs(crs)
    code = parsed.to_epsg() if parsed is not None else None
    if code is None and parsed is not None:
        plan = horizontal_part(parsed)
        code = plan.to_epsg() if plan is not None else None
    if code:
        doc["crs"] = {"type": "name", "properties": {"name": f"urn:ogc:def:crs:EPSG::{code}"}}
    return doc
