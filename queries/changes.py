"""Change detection between two versions of an area (the paper's Comp step).

Tiles of both versions are matched by key at one level. A tile changed when its
category differs and the surface moved by more than the level of detection
(LoD): the surfaces are rebuilt from each version's kept points (on the level's
node lattice, holes bridged by straight lines, no triangulation) and compared at
the tile's 3 × 3 nodes; LoD = 1.96 × √(σ₁² + σ₂²) from the two surveys' measured
ground noise and reduction errors, at least 0.1 m. Changed tiles then grow over
neighbours whose category stayed the same but whose surface moved as well.
Changed tiles that touch and moved the same way (rose or fell) form regions;
a region whose higher surface lies in a layer taken for ground (tdb.evidence)
thicker than its LoD is dropped, and each other one is typed by the filters
that match in one version and not the other.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray
from scipy import ndimage

from queries.centreline import elongation
from queries.coregister import Shift, shifted_lattice, site
from queries.filters import builtin_filters
from queries.grids import shared_tiles
from queries.match import REACH_TILES, match_tiles
from queries.relief import nan_extreme
from tdb.categories import NO_DATA
from tdb.crs import check_same_horizontal
from tdb.database import Database
from tdb.evidence import GAP_SLOPE, MIN_SUPPORT, TileEvidence, supported_change
from tdb.evidence import LEVEL as EVIDENCE_LEVEL
from tdb.geojson import feature
from tdb.outlines import outlines
from tdb.surface import line_rebuild_at
from tdb.tiles import SUBGRID, NodeLattice, node_lattice, tile_key

MIN_LOD = 0.10
# A region smaller than ``min_tiles`` (but of at least MIN_STRONG_TILES) counts when its mean
# change is at least STRONG × LoD: a 20 m² mound 1.9 m high is no noise.
MIN_STRONG_TILES = 4
STRONG = 3.0
# Smaller regions, down to this many tiles, count where a mound or a pit came or went: the
# closed-form filters see the form in one version and not the other, which noise does not make.
MIN_CLOSED_TILES = 2
CLOSED_DZ = 2.0  # × LoD: the least mean change of such a region
CLOSED = ("pit", "mound")
MAX_LOOKUP = 50_000_000  # cells of _member's grid (50 MB)
FINE = 4  # outline cells per node spacing: a quarter of a metre on 2 m tiles
LINE_ELONGATION = 2.0  # a region less elongated than this is compact: no line's change
RULES = (  # (filter, sign of dz, kind when the filter matches in the later version / in the earlier one)
    ("ditch", -1, "ditch dug", "ditch filled"),
    ("ridge", +1, "ridge or wall built", "ridge or wall removed"),
    ("pit", -1, "pit appeared", "pit removed"),
    ("mound", +1, "mound appeared", "mound removed"),
)
# Levels each rule's filter runs at besides its own. A mound or pit a few metres across holds no
# extreme point at 2 m where its top is flat (a ground filter cuts steep tops); at 4 m it does.
EXTRA_LEVELS = {"pit": (4,), "mound": (4,)}


def level_of_detection(db: Database, a: str, b: str, *, shift: Shift | None = None) -> float:
    """95 % level of detection from both surveys' ground noise and the error of their
    surfaces rebuilt from the kept points (the reduction RMSE), at least ``MIN_LOD``; with a
    co-registration ``shift``, at least 1.96 × the residual spread it left on stable ground."""
    residual = 1.96 * shift.nmad if shift is not None and np.isfinite(shift.nmad) else 0.0
    return max(residual, _noise_lod(db, a, b))


def _noise_lod(db: Database, a: str, b: str) -> float:
    terms = []
    for name in (a, b):
        stats = db.version(name).stats
        noise = stats.noise_m if stats.noise_m is not None else 0.05
        terms += [noise, stats.reduction.rmse_m or 0.0]
    return max(MIN_LOD, 1.96 * float(np.sqrt(np.sum(np.square(terms)))))


@dataclass(frozen=True)
class TileJudgement:
    """Per tile of a level, what both versions' ground evidence lets a change claim."""

    lod: NDArray[np.float64]  # m: the level of detection
    seen: NDArray[np.bool_]  # both versions saw the tile's ground well enough
    depth: NDArray[np.float64]  # (2, tiles) m: how far each version's surface may stand above its ground
    layer: NDArray[np.float64]  # (2, tiles) m: the layer each version's surface lies in (tdb.evidence)


def tile_lod(
    db: Database, a: str, b: str, xg: NDArray[np.int64], yg: NDArray[np.int64], *, level: int, lod: float
) -> TileJudgement:
    """Per tile of ``level`` (corners ``xg``, ``yg``), the level of detection grown by both
    versions' ground evidence (:mod:`tdb.evidence`), at least ``lod``; whether both versions
    saw the tile well enough for a change to be claimed; and each version's depth of surface over
    its ground returns. A coarser tile takes the mean of its 2 m tiles. Where a version holds no
    evidence (stored before it was kept) the tile keeps ``lod``, counts as seen and has depth 0."""
    bbox = (float(xg.min()), float(yg.min()), float(xg.max() + level), float(yg.max() + level))
    variance = np.zeros(len(xg))
    seen = np.ones(len(xg), bool)
    depth = np.zeros((2, len(xg)))
    layer = np.zeros((2, len(xg)))
    for side, name in enumerate((a, b)):
        evidence = db.evidence(name, bbox=bbox)
        if len(evidence) == 0:
            continue
        rmse = db.version(name).stats.reduction.rmse_m or 0.0
        sigma2, support, depth[side], layer[side] = _per_tile(evidence, xg, yg, level)
        variance += np.nan_to_num(sigma2, nan=0.0) + rmse**2
        seen &= support >= MIN_SUPPORT
    return TileJudgement(np.maximum(lod, 1.96 * np.sqrt(variance)), seen, depth, layer)


def _per_tile(
    evidence: TileEvidence, xg: NDArray[np.int64], yg: NDArray[np.int64], level: int
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Mean variance of the relief hidden in gaps, mean support, mean standing (how far the
    surface may stand over the ground seen, 0 where nothing is held) and mean layer of the 2 m
    tiles making up each tile of ``level``. A tile's own lift stays out: a wall built or a bank lifts the tiles
    along its edges as vegetation does (the layer, the lift over an area, does not)."""
    k = level // EVIDENCE_LEVEL
    if k == 1:
        e = evidence.at(xg, yg)
    else:
        fx, fy = _split(xg // EVIDENCE_LEVEL // k, yg // EVIDENCE_LEVEL // k, k)
        e = evidence.at(fx * EVIDENCE_LEVEL, fy * EVIDENCE_LEVEL)
    variance = (GAP_SLOPE * e.gap.astype(float)) ** 2
    depth = e.standing
    with np.errstate(invalid="ignore"):
        mean = np.nanmean(variance.reshape(len(xg), k * k), axis=1)
    per = (len(xg), k * k)
    layer = np.nan_to_num(e.layer.astype(float)).reshape(per).mean(axis=1)
    return mean, e.support.reshape(per).mean(axis=1), depth.reshape(per).mean(axis=1), layer


def tile_nodes(xg: NDArray[np.int64], yg: NDArray[np.int64], level: int) -> tuple[NDArray[np.float64], ...]:
    """x and y of each tile's 3 × 3 nodes (corners, edge middles, centre), tile by tile."""
    u, v = np.meshgrid([0.0, 0.5, 1.0], [0.0, 0.5, 1.0])
    return ((xg[:, None] + level * u.ravel()[None, :]).ravel(), (yg[:, None] + level * v.ravel()[None, :]).ravel())


def _lattice(db: Database, version: str, level: int, xg: NDArray[np.int64], yg: NDArray[np.int64]) -> NodeLattice:
    """The version's stored points around the tiles, on the level's node lattice: far enough
    beyond them for the filters' two-sided relief (read once, for surfaces and typing)."""
    grow = REACH_TILES * level + 2 * level
    bbox = (float(xg.min() - grow), float(yg.min() - grow), float(xg.max() + grow), float(yg.max() + grow))
    x, y, z, _ = db.points(version, level=level, bbox=bbox, ordered=False)
    return node_lattice(x, y, z, level)


def _ranges(n: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Lowest and highest stored node along the first axis (+inf and −inf where none)."""
    lo, hi = nan_extreme(n, -1.0, axis=0), nan_extreme(n, 1.0, axis=0)
    none = np.isnan(lo)
    return np.where(none, np.inf, lo), np.where(none, -np.inf, hi)


def _may_move(na: NDArray[np.float64], nb: NDArray[np.float64], lod: NDArray[np.float64]) -> NDArray[np.intp]:
    """Per tile, at most how many of its 3 × 3 nodes can move beyond its ``lod`` (stored nodes
    ``na``, ``nb`` of the two versions), without rebuilding the surfaces.

    The rebuilt surface keeps stored corners as they are; an edge middle is a line between
    stored nodes of its own edge, and the centre a convex mix of the tile's stored nodes.
    So a corner counts when it moved, an edge middle when the ranges of its edge's stored
    nodes allow it, and the centre when the tile's ranges do.
    """
    if len(na) == 0:
        return np.zeros(0, np.intp)
    last = SUBGRID - 1
    # Tiles last: every reduction below runs across whole rows of tiles.
    a, b = (np.ascontiguousarray(np.moveaxis(n, 0, -1)) for n in (na, nb))
    with np.errstate(invalid="ignore"):
        count = (np.abs(b[::last, ::last] - a[::last, ::last]) > lod).sum(axis=(0, 1))  # NaN: never
        for edge in ((0, slice(None)), (last, slice(None)), (slice(None), 0), (slice(None), last)):
            (lo_a, hi_a), (lo_b, hi_b) = _ranges(a[edge]), _ranges(b[edge])
            count += np.maximum(hi_b - lo_a, hi_a - lo_b) > lod  # inf − inf (no stored node): not counted
        (lo_a, hi_a), (lo_b, hi_b) = _ranges(a.reshape(-1, len(na))), _ranges(b.reshape(-1, len(nb)))
        count += np.maximum(hi_b - lo_a, hi_a - lo_b) > lod
    return np.asarray(count, np.intp)


def _surface(nodes: NDArray[np.float64]) -> NDArray[np.float64]:
    """Heights of the line rebuild (:mod:`tdb.surface`) at the 3 × 3 nodes of each tile (NaN: no data)."""
    mid = (SUBGRID - 1) // 2
    cells = np.ravel_multi_index(
        np.meshgrid(np.arange(0, SUBGRID, mid), np.arange(0, SUBGRID, mid), indexing="ij"), (SUBGRID, SUBGRID)
    )
    return line_rebuild_at(nodes, cells.ravel())


@dataclass(frozen=True)
class _Tiles:
    """The tiles both versions hold at one level, their stored points and the LoD."""

    xg: NDArray[np.int64]
    yg: NDArray[np.int64]
    before: NodeLattice
    after: NodeLattice
    judged: TileJudgement

    def moved(self, which: NDArray[np.intp]) -> tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.bool_]]:
        """The tiles ``which`` that can move (indices), the height change at their 3 × 3 nodes,
        and whether each moved: at least three of its nine nodes beyond the LoD, since one node
        alone is often an interpolation difference between the two sets of kept points."""
        which = which[self.judged.seen[which]]
        xg, yg = self.xg[which], self.yg[which]
        na, nb = self.before.tile_nodes(xg, yg), self.after.tile_nodes(xg, yg)
        keep = np.flatnonzero(_may_move(na, nb, self.lod[which]) >= 3)
        surfaces = _surface(np.concatenate([na[keep], nb[keep]]))
        dz = supported_change(surfaces[len(keep) :] - surfaces[: len(keep)], self.judged.depth[:, which[keep]])
        with np.errstate(invalid="ignore"):
            moved = (np.abs(dz) > self.lod[which[keep], None]).sum(axis=1) >= 3
        return which[keep], dz, moved

    @property
    def lod(self) -> NDArray[np.float64]:
        return self.judged.lod


def _regions(
    xg: NDArray[np.int64],
    yg: NDArray[np.int64],
    dz: NDArray[np.float64],
    lod: NDArray[np.float64],
    level: int,
    min_tiles: int,
) -> list[tuple[NDArray[np.intp], float, bool, float]]:
    """Regions of the moved tiles ``xg``, ``yg`` (8-neighbours on the tile lattice that moved the
    same way, :func:`_label_by_sign`) whose mean change passes their LoD (``lod`` per tile; a
    region's is its tiles' median): members, mean height change, whether the region passes the
    size gate by itself (small ones count only where a closed form came or went, see
    :func:`detect`), and the region's LoD."""
    tile_label, n = _label_by_sign(xg, yg, dz, lod, level)
    by_label = np.argsort(tile_label, kind="stable")
    bounds = np.searchsorted(tile_label[by_label], np.arange(1, n + 2))
    regions = []
    for region in range(n):
        members = by_label[bounds[region] : bounds[region + 1]]
        if len(members) < min(min_tiles, MIN_CLOSED_TILES):
            continue
        d = dz[members]
        with np.errstate(invalid="ignore"):
            moved = np.abs(d) > lod[members, None]
        mean_dz = float(np.nanmean(d[moved])) if moved.any() else 0.0
        region_lod = float(np.median(lod[members]))
        # Noise moves nodes both ways and its mean stays inside the LoD; a real change is coherent.
        if abs(mean_dz) < region_lod:
            continue
        strong = len(members) >= MIN_STRONG_TILES and abs(mean_dz) >= STRONG * region_lod
        regions.append((members, mean_dz, len(members) >= min_tiles or strong, region_lod))
    return regions


def _label_by_sign(
    xg: NDArray[np.int64], yg: NDArray[np.int64], dz: NDArray[np.float64], lod: NDArray[np.float64], level: int
) -> tuple[NDArray[np.intp], int]:
    """Region label (1…n) of each tile: tiles that touch (8-neighbours) and moved the same way,
    by the sign of the mean change of their nodes beyond the LoD. Cut beside fill is two changes."""
    with np.errstate(invalid="ignore"):
        beyond = np.abs(dz) > lod[:, None]
    rising = np.where(beyond, dz, 0.0).sum(axis=1) >= 0
    i = ((xg - xg.min()) // level).astype(np.intp)
    j = ((yg - yg.min()) // level).astype(np.intp)
    tile_label = np.zeros(len(xg), np.intp)
    n = 0
    for way in (rising, ~rising):
        grid = np.zeros((j.max() + 1, i.max() + 1), bool)
        grid[j[way], i[way]] = True
        labels, count = ndimage.label(grid, structure=np.ones((3, 3)))
        tile_label[way] = labels[j[way], i[way]] + n
        n += count
    return tile_label, n


def _grow(
    tiles: _Tiles,
    valid: NDArray[np.bool_],
    tested: NDArray[np.intp],
    dz: NDArray[np.float64],
    moved: NDArray[np.bool_],
    seeds: NDArray[np.intp],
    level: int,
) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
    """Grow the changed tiles ``seeds`` over neighbours whose surface moved as well, ring by
    ring until none is added: the tiles (indices into ``tiles.xg``) and their node height changes.

    A wall built across a slope can leave a tile's template unchanged, and a raised
    platform keeps its flat tiles flat: the category change starts a region, and the
    height change decides how far it reaches. ``tested``, ``dz`` and ``moved`` are the
    tiles already compared (those whose category differs).
    """
    xg, yg = tiles.xg, tiles.yg
    i = ((xg - xg.min()) // level).astype(np.intp)
    j = ((yg - yg.min()) // level).astype(np.intp)
    index = np.full((j.max() + 3, i.max() + 3), -1, np.intp)  # a border of −1 around the tiles
    index[j + 1, i + 1] = np.arange(len(xg))
    row = np.full(len(xg), -1, np.intp)  # each compared tile's row in the parts below; −2: did not move
    row[tested] = np.where(moved, np.arange(len(tested)), -2)
    row[~valid] = -2
    parts = [dz]
    taken = np.zeros(len(xg), bool)
    taken[seeds] = True
    new, count = seeds, len(tested)
    ring = np.array([(di, dj) for di in (-1, 0, 1) for dj in (-1, 0, 1) if di or dj])
    while len(new):
        near = index[j[new, None] + 1 + ring[:, 1], i[new, None] + 1 + ring[:, 0]].ravel()
        near = np.unique(near[near >= 0])
        near = near[~taken[near] & (row[near] != -2)]
        unknown = near[row[near] == -1]
        if len(unknown):
            t, d, m = tiles.moved(unknown)
            row[unknown] = -2
            row[t[m]] = count + np.arange(int(m.sum()))
            parts.append(d[m])
            count += int(m.sum())
        new = near[row[near] >= 0]
        taken[new] = True
    out = np.flatnonzero(taken)
    return out, np.concatenate(parts)[row[out]]


def detect(
    db: Database,
    before: str,
    after: str,
    *,
    level: int = 2,
    bbox: tuple[float, float, float, float] | None = None,
    min_tiles: int = 8,
    shift: Shift | None = None,
) -> list[dict[str, Any]]:
    """Changed regions between ``before`` and ``after`` as GeoJSON feature dicts.

    ``shift`` (:func:`queries.coregister.coregister`) aligns ``after`` to ``before`` first, and
    the level of detection is then at least what the residual on stable ground allows.

    Raises
    ------
    CRSError
        If the versions' horizontal coordinate systems differ.
    """
    check_same_horizontal(db.crs(before), db.crs(after), names=(before, after), at=site(db, before))
    xg, yg, c1, c2 = shared_tiles(db, before, after, level=level, bbox=bbox)
    if len(xg) == 0:
        return []
    valid = (c1 != NO_DATA) & (c2 != NO_DATA)
    # Only tiles whose category differs can start a change: the surfaces are rebuilt around them alone.
    differ = np.flatnonzero((c1 != c2) & valid)
    if len(differ) == 0:
        return []
    lod = level_of_detection(db, before, after, shift=shift)
    lattices = {name: _lattice(db, name, level, xg[differ], yg[differ]) for name in (before, after)}
    if shift is not None and shift.applied:
        lattices[after] = shifted_lattice(lattices[after], shift)
    tiles = _Tiles(
        xg, yg, lattices[before], lattices[after], tile_lod(db, before, after, xg, yg, level=level, lod=lod)
    )
    tested, dz, moved = tiles.moved(differ)
    if not moved.any():
        return []
    first = tested[moved]
    candidates = _regions(xg[first], yg[first], dz[moved], tiles.lod[first], level, min_tiles)
    # Small regions grow too; they are kept at the end only where a closed form came or went.
    strong = [first[m] for m, _, big, _ in candidates if big]
    weak = [first[m] for m, d, big, at in candidates if not big and abs(d) >= CLOSED_DZ * at]
    if not strong and not weak:
        return []
    grown, dz = _grow(tiles, valid, tested, dz, moved, np.concatenate(strong + weak), level)
    from_strong = np.isin(grown, np.concatenate(strong)) if strong else np.zeros(len(grown), bool)
    lods = tiles.lod[grown]
    layers = tiles.judged.layer[:, grown]
    xg, yg = xg[grown], yg[grown]
    # A grown region is sure where it holds a strong seed, or where it is large and moved as a
    # whole by a strong change: a form removed from a steep slope changes few categories, so its
    # seeds are weak, but its grown surface still says plainly that it moved.
    regions = [
        (members, mean_dz, big and (bool(from_strong[members].any()) or abs(mean_dz) >= STRONG * at), at)
        for members, mean_dz, big, at in _regions(xg, yg, dz, lods, level, min_tiles)
        if big or abs(mean_dz) >= CLOSED_DZ * at
    ]
    if not regions:
        return []
    groups = [m for m, *_ in regions]
    found = {name: _matched(db, name, xg, yg, groups, level, lattices[name]) for name in (before, after)}
    out = []
    for (members, mean_dz, sure, region_lod), was, now in zip(regions, found[before], found[after]):
        if not sure and not _closed_form_changed(was, now, mean_dz):
            continue
        if _under_a_layer(layers, members, mean_dz, region_lod):
            continue
        x, y = xg[members], yg[members]
        geom = outline(x, y, dz[members], lods[members], mean_dz, level=level)
        compact = elongation(x.astype(float), y.astype(float), level=level) < LINE_ELONGATION
        props = {
            "kind": _kind(was, now, mean_dz, compact=compact),
            "tiles": len(members),
            "area": float(geom.area),
            "dz": round(mean_dz, 3),
            "level": level,
            "lod": round(region_lod, 3),
        }
        out.append(feature(geom, props))
    return out


def _under_a_layer(layers: NDArray[np.float64], members: NDArray[np.intp], mean_dz: float, lod: float) -> bool:
    """Whether a region's higher surface (the later one where it rose, the earlier where it fell)
    lies in a layer taken for ground thicker than the level of detection (the median of its
    tiles', ``layers``: 2 × tiles). Under such a layer, vegetation's top, no return of that survey
    reached the ground, and the layer's lift says only how rough its top is, not how far it
    stands over the ground: the survey does not say where the ground was."""
    return bool(np.median(layers[1 if mean_dz > 0 else 0, members]) > lod)


def outline(
    xg: NDArray[np.int64],
    yg: NDArray[np.int64],
    dz: NDArray[np.float64],
    lod: NDArray[np.float64],
    mean_dz: float,
    *,
    level: int,
) -> shapely.Geometry:
    """A region's outline: the LoD contour of its height change, the way the region moved.

    The change at its tiles' (``xg``, ``yg``) 3 × 3 nodes (``dz``, tiles × 9), over each tile's
    ``lod``, runs linearly (bilinearly) between the nodes, as the surfaces rebuilt from kept points
    do between their nodes; the outline holds the tiles' area where that ratio passes 1, drawn
    on cells :data:`FINE` times finer than the nodes. The tiles themselves where no node moved.

    A tile moves when a third of its nodes do, so a tile on a region's edge holds ground that
    stayed as well; and where the change falls off from a node far beyond the LoD to one within
    it, the contour lies nearer the latter, not halfway."""
    sign = np.sign(mean_dz)
    ratio = np.nan_to_num(dz * sign / lod[:, None], nan=0.0)
    if not (ratio > 1.0).any():
        return shapely.coverage_union_all(shapely.box(xg, yg, xg + level, yg + level))  # tiles never overlap
    x0, y0 = int(xg.min()), int(yg.min())
    ti, tj = (xg - x0) // level, (yg - y0) // level
    fine = _bilinear(_node_grid(ti, tj, ratio), FINE)
    tile = np.zeros((int(tj.max()) + 1, int(ti.max()) + 1), bool)
    tile[tj, ti] = True
    inside = tile[np.arange(fine.shape[0]) // (2 * FINE)][:, np.arange(fine.shape[1]) // (2 * FINE)]
    moved = np.where((fine > 1.0) & inside, 0, -1)
    return outlines(moved, x0=float(x0), y0=float(y0), cell=level / 2 / FINE).get(0, shapely.Polygon())


def _node_grid(ti: NDArray[np.int64], tj: NDArray[np.int64], values: NDArray[np.float64]) -> NDArray[np.float64]:
    """The tiles' (column ``ti``, row ``tj``) 3 × 3 node ``values`` on one grid of nodes, rows
    south to north; a node shared by tiles takes their mean, a node of no tile 0."""
    u, v = np.meshgrid([0, 1, 2], [0, 1, 2])
    ni, nj = (2 * ti[:, None] + u.ravel()).ravel(), (2 * tj[:, None] + v.ravel()).ravel()
    shape = (2 * int(tj.max()) + 3, 2 * int(ti.max()) + 3)
    total, count = np.zeros(shape), np.zeros(shape)
    np.add.at(total, (nj, ni), values.ravel())
    np.add.at(count, (nj, ni), 1.0)
    return total / np.maximum(count, 1.0)


def _bilinear(nodes: NDArray[np.float64], fine: int) -> NDArray[np.float64]:
    """``nodes`` interpolated bilinearly at the centres of ``fine`` × ``fine`` cells per square
    between four nodes: (rows − 1) · fine × (columns − 1) · fine values."""
    t = (np.arange(fine) + 0.5) / fine
    along = (nodes[:, :-1, None] * (1 - t) + nodes[:, 1:, None] * t).reshape(nodes.shape[0], -1)
    return (along[:-1, None, :] * (1 - t)[:, None] + along[1:, None, :] * t[:, None]).reshape(-1, along.shape[1])


def _closed_form_changed(before: dict[str, float], after: dict[str, float], mean_dz: float) -> bool:
    """Whether a mound or a pit came or went, in the direction of the change (a mound gone or a
    pit dug where the ground fell): the matched areas of the closed-form filters, per version."""
    return any(
        (after.get(name, 0.0) - before.get(name, 0.0)) * sign * np.sign(mean_dz) > 0
        for name, sign, *_ in RULES
        if name in CLOSED
    )


def _member(
    kx: NDArray[np.int64],
    ky: NDArray[np.int64],
    sx: NDArray[np.int64],
    sy: NDArray[np.int64],
    *,
    max_cells: int = MAX_LOOKUP,
) -> NDArray[np.bool_]:
    """Whether each integer key (kx, ky) is one of the keys (sx, sy): a lookup in a grid over the
    keys' extent (regions are compact), several times faster than sorting both for ``np.isin``."""
    out = np.zeros(len(kx), bool)
    if len(sx) == 0 or len(kx) == 0:
        return out
    x0, y0 = int(sx.min()), int(sy.min())
    shape = (int(sy.max()) - y0 + 1, int(sx.max()) - x0 + 1)
    if shape[0] * shape[1] > max_cells:  # keys spread over a vast area: sort instead
        return np.isin(tile_key(kx, ky), tile_key(sx, sy))
    grid = np.zeros(shape, bool)
    grid[sy - y0, sx - x0] = True
    i, j = kx - x0, ky - y0
    ok = (i >= 0) & (j >= 0) & (i < grid.shape[1]) & (j < grid.shape[0])
    out[ok] = grid[j[ok], i[ok]]
    return out


def _split(
    kx: NDArray[np.int64], ky: NDArray[np.int64], factor: int
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Keys of the factor × factor finer tiles making up each tile, tile by tile."""
    d = np.arange(factor)
    shape = (len(kx), factor, factor)
    fx = np.broadcast_to(kx[:, None, None] * factor + d[None, None, :], shape)
    fy = np.broadcast_to(ky[:, None, None] * factor + d[None, :, None], shape)
    return fx.ravel(), fy.ravel()


def _matched(
    db: Database,
    version: str,
    xg: NDArray[np.int64],
    yg: NDArray[np.int64],
    regions: list[NDArray[np.intp]],
    level: int,
    lattice: NodeLattice,
) -> list[dict[str, float]]:
    """Per region (indices into the ``level`` tiles ``xg``, ``yg``), the area (m²) of its
    tiles that each rule's filter matches in ``version``.

    The filters run on the tiles in and around the regions only (one tile beyond
    them, so that an object cut by the region's edge still shows its form). All
    geometry is done on integer tile keys: the tiles of two levels nest exactly.
    ``lattice`` holds the version's points at ``level`` around the regions.
    """
    filters = builtin_filters()
    members = np.concatenate(regions)
    owner = np.repeat(np.arange(len(regions)), [len(r) for r in regions])
    out: list[dict[str, float]] = [{} for _ in regions]
    runs = {(name, lv) for name, *_ in RULES for lv in (filters[name].level, *EXTRA_LEVELS.get(name, ()))}
    for lv in sorted({lv for _, lv in runs}):
        cx, cy = np.unique(np.column_stack([xg[members] // lv, yg[members] // lv]), axis=0).T
        ring = np.array([(dx, dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1)])
        nx, ny = (cx[:, None] + ring[:, 0]).ravel(), (cy[:, None] + ring[:, 1]).ravel()
        bbox = (float(nx.min() * lv), float(ny.min() * lv), float((nx.max() + 1) * lv), float((ny.max() + 1) * lv))
        txg, tyg, code = db.tiles(version, level=lv, bbox=bbox, ordered=False)
        if len(txg) == 0:
            continue
        among = _member(txg // lv, tyg // lv, nx, ny)
        txg, tyg, code = txg[among], tyg[among], code[among]
        lat = lattice
        if lv != level:
            grow = REACH_TILES * lv + lv
            px, py, pz, _ = db.points(
                version,
                level=lv,
                bbox=(bbox[0] - grow, bbox[1] - grow, bbox[2] + grow, bbox[3] + grow),
                ordered=False,
            )
            lat = node_lattice(px, py, pz, lv)
        # Regions and matches meet on the finer of the two tile lattices.
        fine = min(lv, level)
        rx, ry = _split(xg[members] // level, yg[members] // level, level // fine)
        region_owner = np.repeat(owner, (level // fine) ** 2)
        for name, *_ in RULES:
            flt = filters[name]
            if (name, lv) not in runs:
                continue
            found = match_tiles(txg, tyg, code, lat, flt, level=lv, shapes=False)
            tiles = np.concatenate([m.tiles for m in found]) if found else np.zeros(0, np.intp)
            mx, my = _split(txg[tiles] // lv, tyg[tiles] // lv, lv // fine)
            inside = _member(rx, ry, mx, my)
            area = np.bincount(region_owner[inside], minlength=len(regions)) * float(fine * fine)
            for k in range(len(regions)):  # the level that matches most of the region counts
                out[k][name] = max(out[k].get(name, 0.0), float(area[k]))
    return out


def _kind(before: dict[str, float], after: dict[str, float], mean_dz: float, *, compact: bool = False) -> str:
    """The rule whose filter gained (or lost) most matched area, in the direction of the height change.

    In a ``compact`` region (not elongated) a mound or pit that came or went names it before any
    line: a dome's crest makes ridge tiles too, while a line's change is a long region.
    """
    best, best_gain = "raised" if mean_dz > 0 else "lowered", 0.0
    rules: tuple[tuple[str, int, str, str], ...] = RULES
    if compact and _closed_form_changed(before, after, mean_dz):
        rules = tuple(r for r in RULES if r[0] in CLOSED)
    for name, sign, appeared, gone in rules:
        gain = after.get(name, 0.0) - before.get(name, 0.0)
        if gain > best_gain and np.sign(mean_dz) == sign:
            best, best_gain = appeared, gain
        if -gain > best_gain and np.sign(mean_dz) == -sign:
            best, best_gain = gone, -gain
    return best
