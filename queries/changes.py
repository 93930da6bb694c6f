"""Change detection between two versions of an area (the paper's Comp step).

Tiles of both versions are matched by key at one level. A tile changed when its
category differs and the surface moved by more than the level of detection
(LoD): the surfaces are rebuilt from each version's kept points (on the level's
node lattice, holes bridged by straight lines, no triangulation) and compared at
the tile's 3 × 3 nodes, only where the categories differ; LoD = 1.96 × √(σ₁² + σ₂²) from the two surveys' measured
ground noise, at least 0.1 m. Changed tiles that touch form regions; each region
is typed by the filters that match in one version and not the other.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray
from scipy import ndimage

from ingest.ground.fill import fill_lines
from queries.filters import builtin_filters
from queries.match import REACH_TILES, match_tiles
from queries.relief import SUBGRID, node_lattice
from tdb.categories import NO_DATA
from tdb.database import Database

MIN_LOD = 0.10
RULES = (  # (filter, sign of dz, kind when the filter matches in the later version / in the earlier one)
    ("ditch", -1, "ditch dug", "ditch filled"),
    ("ridge", +1, "ridge or wall built", "ridge or wall removed"),
    ("pit", -1, "pit appeared", "pit removed"),
    ("mound", +1, "mound appeared", "mound removed"),
)


def level_of_detection(db: Database, a: str, b: str) -> float:
    """95 % level of detection from both surveys' ground noise and the error of their
    surfaces rebuilt from the kept points (the reduction RMSE), at least ``MIN_LOD``."""
    terms = []
    for name in (a, b):
        stats = db.version(name).stats
        terms += [float(stats.get("noise_m", 0.05)), float(stats.get("rmse_m", 0.0))]
    return max(MIN_LOD, 1.96 * float(np.sqrt(np.sum(np.square(terms)))))


def tile_nodes(xg: NDArray[np.int64], yg: NDArray[np.int64], level: int) -> tuple[NDArray[np.float64], ...]:
    """x and y of each tile's 3 × 3 nodes (corners, edge middles, centre), tile by tile."""
    u, v = np.meshgrid([0.0, 0.5, 1.0], [0.0, 0.5, 1.0])
    return ((xg[:, None] + level * u.ravel()[None, :]).ravel(), (yg[:, None] + level * v.ravel()[None, :]).ravel())


def _surface(
    db: Database,
    version: str,
    level: int,
    xg: NDArray[np.int64],
    yg: NDArray[np.int64],
) -> NDArray[np.float64]:
    """Heights of the version's rebuilt surface at the 3 × 3 nodes of each tile (NaN: no data).

    Within a tile the kept nodes (the corners and the feature's nodes) stand for
    planes between them; the nodes between are bridged by straight lines along the
    tile's rows and columns, which is what a triangulation would give, without one.
    """
    bbox = (float(xg.min()), float(yg.min()), float(xg.max() + level), float(yg.max() + level))
    x, y, z, _ = db.points(version, level=level, bbox=bbox)
    nodes = fill_lines(node_lattice(x, y, z, level).tile_nodes(xg, yg))
    mid = (SUBGRID - 1) // 2
    return np.asarray(nodes[:, ::mid, ::mid].reshape(len(xg), 9), np.float64)


def detect(
    db: Database,
    before: str,
    after: str,
    *,
    level: int = 2,
    bbox: tuple[float, float, float, float] | None = None,
    min_tiles: int = 8,
) -> list[dict[str, Any]]:
    """Changed regions between ``before`` and ``after`` as GeoJSON feature dicts."""
    xa, ya, ca = db.tiles(before, level=level, bbox=bbox)
    xb, yb, cb = db.tiles(after, level=level, bbox=bbox)
    key_a = xa.astype(np.int64) * 100_000_000 + ya
    key_b = xb.astype(np.int64) * 100_000_000 + yb
    _, ia, ib = np.intersect1d(key_a, key_b, return_indices=True)
    if len(ia) == 0:
        return []
    xg, yg, c1, c2 = xa[ia], ya[ia], ca[ia], cb[ib]
    # Only tiles whose category differs can change: the surfaces are rebuilt around them alone.
    differ = np.flatnonzero((c1 != c2) & (c1 != NO_DATA) & (c2 != NO_DATA))
    if len(differ) == 0:
        return []
    xg, yg, c1, c2 = xg[differ], yg[differ], c1[differ], c2[differ]
    dz = _surface(db, after, level, xg, yg) - _surface(db, before, level, xg, yg)
    lod = level_of_detection(db, before, after)
    # A tile moved when at least three of its nine nodes moved beyond the LoD: one node
    # alone is often an interpolation difference between the two sets of kept points.
    with np.errstate(invalid="ignore"):
        changed = (np.abs(dz) > lod).sum(axis=1) >= 3
    if not changed.any():
        return []
    # Regions: changed tiles touching (8-neighbours) on the tile lattice.
    i = ((xg - xg.min()) // level).astype(np.intp)
    j = ((yg - yg.min()) // level).astype(np.intp)
    grid = np.zeros((j.max() + 1, i.max() + 1), bool)
    grid[j[changed], i[changed]] = True
    labels, n = ndimage.label(grid, structure=np.ones((3, 3)))
    tile_label = labels[j, i]
    regions = []
    for region in range(1, n + 1):
        members = np.flatnonzero(tile_label == region)
        if len(members) < min_tiles:
            continue
        d = dz[members]
        moved = np.abs(d) > lod
        mean_dz = float(np.nanmean(d[moved])) if moved.any() else 0.0
        # Noise moves nodes both ways and its mean stays inside the LoD; a real change is coherent.
        if abs(mean_dz) < lod:
            continue
        geom = shapely.union_all(
            [shapely.box(x, y, x + level, y + level) for x, y in zip(xg[members], yg[members])]
        )
        regions.append((members, mean_dz, geom))
    if not regions:
        return []
    shapes = [g for _, _, g in regions]
    found = {name: _matched(db, name, shapes) for name in (before, after)}
    out = []
    for (members, mean_dz, geom), was, now in zip(regions, found[before], found[after]):
        out.append(
            {
                "type": "Feature",
                "geometry": shapely.geometry.mapping(geom),
                "properties": {
                    "kind": _kind(was, now, mean_dz),
                    "tiles": len(members),
                    "area": float(geom.area),
                    "dz": round(mean_dz, 3),
                    "level": level,
                    "lod": round(lod, 3),
                },
            }
        )
    return out


def _matched(db: Database, version: str, regions: list[shapely.Geometry]) -> list[dict[str, float]]:
    """Per region, the area (m²) of the tiles each rule's filter matches in ``version``.

    The filters run on the tiles in and around the regions only (one tile beyond
    them, so that an object cut by the region's edge still shows its form).
    """
    filters = builtin_filters()
    out: list[dict[str, float]] = [{} for _ in regions]
    for level in sorted({filters[name].level for name, *_ in RULES}):
        near = shapely.union_all(regions).buffer(level)
        x0, y0, x1, y1 = near.bounds
        xg, yg, code = db.tiles(version, level=level, bbox=(x0, y0, x1, y1))
        if len(xg) == 0:
            continue
        boxes = shapely.box(xg, yg, xg + level, yg + level)
        among = shapely.intersects(near, boxes)
        grow = REACH_TILES * level + level
        px, py, pz, _ = db.points(version, level=level, bbox=(x0 - grow, y0 - grow, x1 + grow, y1 + grow))
        lattice = node_lattice(px, py, pz, level)
        for name, *_ in RULES:
            flt = filters[name]
            if flt.level != level:
                continue
            tiles = [t for m in match_tiles(xg, yg, code, lattice, flt, level=level, among=among) for t in m.tiles]
            matched = shapely.union_all(boxes[tiles]) if tiles else shapely.Polygon()
            for k, region in enumerate(regions):
                out[k][name] = float(matched.intersection(region).area)
    return out


def _kind(before: dict[str, float], after: dict[str, float], mean_dz: float) -> str:
    """The rule whose filter gained (or lost) most matched area, in the direction of the height change."""
    best, best_gain = "raised" if mean_dz > 0 else "lowered", 0.0
    for name, sign, appeared, gone in RULES:
        gain = after.get(name, 0.0) - before.get(name, 0.0)
        if gain > best_gain and np.sign(mean_dz) == sign:
            best, best_gain = appeared, gain
        if -gain > best_gain and np.sign(mean_dz) == -sign:
            best, best_gain = gone, -gain
    return best
