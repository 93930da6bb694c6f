"""Find objects in a stored survey with a feature filter."""

from __future__ import annotations

import numpy as np
import shapely
from numpy.typing import NDArray

from queries.filters import Filter, Match, builtin_filters, components, tile_lines
from tdb.database import Database
from tdb.errors import FilterError


def resolve(name_or_filter: str | Filter) -> Filter:
    if isinstance(name_or_filter, Filter):
        return name_or_filter
    known = builtin_filters()
    if name_or_filter not in known:
        raise FilterError(f"no filter {name_or_filter!r}; built in: {', '.join(sorted(known))}")
    return known[name_or_filter]


def find(
    db: Database,
    version: str,
    name_or_filter: str | Filter,
    *,
    level: int | None = None,
    bbox: tuple[float, float, float, float] | None = None,
) -> list[Match]:
    """Objects matching a filter at ``level`` (default: the filter's own) inside ``bbox``."""
    flt = resolve(name_or_filter)
    lv = level or flt.level
    xg, yg, code = db.tiles(version, level=lv, bbox=bbox)
    groups = components(xg, yg, code, flt, lv)
    if not groups:
        return []
    px, py, pz, _ = db.points(
        version, level=lv, bbox=None if bbox is None else (bbox[0] - lv, bbox[1] - lv, bbox[2] + lv, bbox[3] + lv)
    )
    heights = _height_lookup(px, py, pz, lv)
    lines = tile_lines(xg, yg, code, lv) if flt.linear else []
    out = []
    for g in groups:
        measure = float(np.nanmean([_relief(heights, int(xg[t]), int(yg[t]), lv, flt.measure) for t in g]))
        if measure < flt.min_measure:  # NaN (no relief measured) is kept
            continue
        if flt.linear:
            parts = [lines[t] for t in g if lines[t] is not None]
            geom = shapely.line_merge(shapely.union_all(parts))
            length = float(geom.length)
        else:
            geom = shapely.union_all([shapely.box(xg[t], yg[t], xg[t] + lv, yg[t] + lv) for t in g])
            length = 0.0
        out.append(Match(flt.name, lv, g, geom, length, measure))
    return out


def _height_lookup(
    x: NDArray[np.float64], y: NDArray[np.float64], z: NDArray[np.float64], level: int
) -> dict[tuple[int, int], float]:
    s = level / 4
    return {(round(a / s), round(b / s)): float(c) for a, b, c in zip(x, y, z)}


def _relief(heights: dict[tuple[int, int], float], xg: int, yg: int, level: int, measure: str) -> float:
    """Depth (corners' mean − lowest kept node) or height (highest node − corners' mean) of one tile."""
    s = level / 4
    i0, j0 = round(xg / s), round(yg / s)
    corners = [heights.get((i0 + a, j0 + b)) for a in (0, 4) for b in (0, 4)]
    nodes = [heights.get((i0 + a, j0 + b)) for a in range(5) for b in range(5)]
    cz = [v for v in corners if v is not None]
    nz = [v for v in nodes if v is not None]
    if not cz or not nz:
        return float("nan")
    return float(np.mean(cz) - min(nz)) if measure == "depth" else float(max(nz) - np.mean(cz))
