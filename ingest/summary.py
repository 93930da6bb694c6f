"""What is in a point cloud: counts, extent, units, density, classes, returns."""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from tdb.bbox import column_range
from tdb.cloud import PointCloud
from tdb.units import epsg_of, units_of

CLASS_NAMES = {
    0: "never classified",
    1: "unclassified",
    2: "ground",
    3: "low vegetation",
    4: "medium vegetation",
    5: "high vegetation",
    6: "building",
    7: "low noise",
    8: "key point",
    9: "water",
    10: "rail",
    11: "road surface",
    12: "overlap",
    17: "bridge deck",
    18: "high noise",
}


DENSITY_CELL = 2.0


def occupied_area(xy: np.ndarray, *, cell: float) -> float:
    """Area of the ``cell``-sized grid cells that hold at least one point."""
    ij = np.floor((xy - column_range(xy)[0]) / cell).astype(np.int64)
    keys = ij[:, 0] * (int(ij[:, 1].max()) + 1) + ij[:, 1]
    return float(len(np.unique(keys))) * cell * cell


def summarize(cloud: PointCloud) -> dict[str, Any]:
    """Facts about ``cloud`` as plain data (JSON-ready).

    Density is points per square metre of occupied 2 m cells (cells holding at
    least one point), so gaps and open water do not dilute it; the convex-hull
    area is reported beside it. Areas are in square metres whatever the CRS units.
    """
    units = units_of(cloud.crs)
    h_factor = units.horizontal_factor if units and not units.geographic else 1.0
    try:
        hull_area = float(ConvexHull(cloud.xyz[:, :2]).volume) * h_factor**2
    except (QhullError, ValueError):
        hull_area = 0.0
    xy_m = cloud.xyz[:, :2] * h_factor
    occupied_m2 = occupied_area(xy_m, cell=DENSITY_CELL)
    classes, class_counts = np.unique(cloud.classification, return_counts=True)
    returns, return_counts = np.unique(cloud.return_number, return_counts=True)
    first = int((cloud.return_number == 1).sum())
    return {
        "source": cloud.source,
        "points": len(cloud),
        "bounds": [round(v, 3) for v in cloud.bounds],
        "crs": None if cloud.crs is None else cloud.crs.name,
        "epsg": epsg_of(cloud.crs),
        "horizontal_units": units.horizontal if units else "unknown (no CRS)",
        "vertical_units": units.vertical if units else "unknown (no CRS)",
        "hull_area_m2": round(hull_area, 1),
        "occupied_area_m2": round(occupied_m2, 1),
        "density_per_m2": round(len(cloud) / occupied_m2, 3),
        "first_return_density_per_m2": round(first / occupied_m2, 3),
        "classification": {
            f"{int(c)} {CLASS_NAMES.get(int(c), 'other')}": int(n) for c, n in zip(classes, class_counts)
        },
        "returns": {int(r): int(n) for r, n in zip(returns, return_counts)},
        **{k: v for k, v in cloud.meta.items() if k in ("las_version", "point_format")},
    }


def format_summary(info: dict[str, Any]) -> str:
    """Human-readable lines for :func:`summarize` output."""
    b = info["bounds"]
    crs = info["crs"] or "none recorded"
    if info["epsg"]:
        crs = f"{crs} (EPSG:{info['epsg']})"
    lines = [
        f"file:        {info['source']}",
        f"points:      {info['points']:,}",
        f"bounds:      x {b[0]} .. {b[3]}, y {b[1]} .. {b[4]}, z {b[2]} .. {b[5]}",
        f"crs:         {crs}",
        f"units:       horizontal {info['horizontal_units']}, vertical {info['vertical_units']}",
        f"area:        {info['occupied_area_m2']:,} m² in occupied 2 m cells, "
        f"{info['hull_area_m2']:,} m² convex hull",
        f"density:     {info['density_per_m2']} points/m², "
        f"{info['first_return_density_per_m2']} first returns/m² (occupied cells)",
        "classes:     " + ", ".join(f"{k}: {v:,}" for k, v in info["classification"].items()),
        "returns:     " + ", ".join(f"#{k}: {v:,}" for k, v in info["returns"].items()),
    ]
    if "las_version" in info:
        lines.append(f"format:      LAS {info['las_version']}, point format {info['point_format']}")
    return "\n".join(lines)
