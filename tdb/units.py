"""Units and coordinate systems: what a CRS measures in, and conversion to metres.

tdb works in metres. A projected CRS in feet is replaced by the same CRS with
metre axes (coordinates scaled exactly); a geographic CRS is projected to its
UTM zone; a cloud with no CRS is taken as metres only when the caller says so.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pyproj
from pyproj.aoi import AreaOfInterest
from pyproj.database import query_utm_crs_info

from tdb.cloud import PointCloud
from tdb.crs import as_crs, epsg_of
from tdb.errors import CRSError, Remedy

__all__ = ["METRES", "Units", "as_crs", "epsg_of", "to_metres", "units_of", "with_metre_axes"]


@dataclass(frozen=True)
class Units:
    """Horizontal and vertical units of a CRS with their size in metres."""

    horizontal: str
    horizontal_factor: float
    vertical: str
    vertical_factor: float
    geographic: bool = False

    @property
    def metric(self) -> bool:
        return self.horizontal_factor == 1.0 and self.vertical_factor == 1.0 and not self.geographic


METRES = Units("metre", 1.0, "metre", 1.0)


def _axis_unit(axes: list[Any], directions: tuple[str, ...]) -> tuple[str, float] | None:
    for axis in axes:
        if axis.direction.lower() in directions:
            return axis.unit_name, float(axis.unit_conversion_factor)
    return None


def units_of(crs: pyproj.CRS | None) -> Units | None:
    """Units of ``crs``; None where no CRS is known."""
    if crs is None:
        return None
    horizontal_crs = crs.sub_crs_list[0] if crs.is_compound else crs
    h = _axis_unit(horizontal_crs.axis_info, ("east", "north", "west", "south"))
    if h is None:
        raise CRSError(f"coordinate system {crs.name!r} has no horizontal axes")
    geographic = horizontal_crs.is_geographic
    v = None
    if crs.is_compound and len(crs.sub_crs_list) > 1:
        v = _axis_unit(crs.sub_crs_list[1].axis_info, ("up", "down"))
    if v is None:
        v = _axis_unit(horizontal_crs.axis_info, ("up",))
    if v is None:
        # A 2-D CRS says nothing of heights: the convention is that they share
        # the horizontal linear unit.
        v = ("metre", 1.0) if geographic else h
    return Units(h[0], 1.0 if geographic else h[1], v[0], v[1], geographic)


def with_metre_axes(crs: pyproj.CRS) -> pyproj.CRS:
    """The same CRS with every linear axis in metres (projection parameters unchanged)."""
    doc = crs.to_json_dict()
    nodes = [doc, *doc.get("components", [])]
    for node in nodes:
        for axis in node.get("coordinate_system", {}).get("axis", []):
            if axis.get("unit") != "degree":
                axis["unit"] = "metre"
        node.pop("id", None)
    doc["name"] = f"{crs.name} (metre axes)"
    doc.pop("id", None)
    return pyproj.CRS.from_json_dict(doc)


def to_metres(cloud: PointCloud, *, assume_metres: bool = False) -> PointCloud:
    """Return ``cloud`` with coordinates in metres and a CRS that says so.

    Parameters
    ----------
    cloud : the points, in the units of their CRS.
    assume_metres : accept a cloud with no CRS as metres; otherwise that is an error.

    Raises
    ------
    CRSError
        If the cloud has no CRS and ``assume_metres`` is false.
    """
    if cloud.crs is None:
        if not assume_metres:
            raise CRSError(
                f"{cloud.source}: no coordinate system; give one, or say the coordinates are metres",
                remedy=Remedy.GIVE_CRS,
            )
        return cloud
    units = units_of(cloud.crs)
    assert units is not None
    if units.metric:
        return cloud
    if units.geographic:
        return _project_to_utm(cloud, units)
    xyz = cloud.xyz.copy()
    xyz[:, :2] *= units.horizontal_factor
    xyz[:, 2] *= units.vertical_factor
    meta = dict(cloud.meta, converted_from=f"{units.horizontal}/{units.vertical}")
    return replace(cloud, xyz=xyz, crs=with_metre_axes(cloud.crs), meta=meta)


def _project_to_utm(cloud: PointCloud, units: Units) -> PointCloud:
    lon0, lat0, _, lon1, lat1, _ = cloud.bounds
    hits = query_utm_crs_info(datum_name="WGS 84", area_of_interest=AreaOfInterest(lon0, lat0, lon1, lat1))
    if not hits:
        raise CRSError(f"{cloud.source}: no UTM zone covers lon {lon0}..{lon1}, lat {lat0}..{lat1}")
    utm = pyproj.CRS.from_epsg(hits[0].code)
    transformer = pyproj.Transformer.from_crs(cloud.crs, utm, always_xy=True)
    x, y = transformer.transform(cloud.x, cloud.y)
    xyz = np.column_stack([x, y, cloud.z * units.vertical_factor])
    meta = dict(cloud.meta, converted_from=str(cloud.crs.name))
    return replace(cloud, xyz=xyz, crs=utm, meta=meta)
