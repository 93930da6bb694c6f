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
thicker than its LoD is dropped, and so is one whose higher surface the other survey saw over
a third of it and did not take for ground, and one where most pulses of the survey whose
surface stands higher did not reach what it took for ground; each other one is typed by the
filters that match in one version and not the other.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray
from scipy import ndimage

from queries.centreline import elongation
from queries.change_parts import MovedTiles, moved_by_parts, reached
from queries.coregister import Shift, shifted_lattice, site
from queries.filters import builtin_filters
from queries.grids import shared_tiles
from queries.match import REACH_TILES, match_tiles
from queries.parts import part_side, parts_for
from queries.tile_change import MovingTiles, Sides, level_of_detection, split_keys, tile_lattice, tile_lod
from tdb.categories import NO_DATA
from tdb.crs import check_same_horizontal
from tdb.database import Database
from tdb.evidence import too_few_returns, under_cover
from tdb.geojson import feature
from tdb.outlines import outlines
from tdb.progress import Progress
from tdb.tiles import NodeLattice, node_lattice, tile_key

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
CONTOUR = 1.0  # × LoD: the change a region's outline is drawn at
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


def _regions(t: _Grown, level: int, min_tiles: int) -> list[tuple[NDArray[np.intp], float, bool, float]]:
    """Regions of the moved tiles ``t`` (8-neighbours on the tile lattice that moved the
    same way, :func:`_label_by_sign`) whose mean change passes their LoD (``lod`` per tile; a
    region's is its tiles' median): members, mean height change, whether the region passes the
    size gate by itself (small ones count only where a closed form came or went, see
    :func:`detect`), and the region's LoD."""
    dz, lod = t.dz, t.lod
    tile_label, n = _label_by_sign(t.xg, t.yg, dz, lod, level)
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


Compared = tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]


def _grow(
    tiles: MovingTiles, valid: NDArray[np.bool_], compared: Compared, seeds: NDArray[np.intp], level: int
) -> tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64]]:
    """Grow the changed tiles ``seeds`` over neighbours whose surface moved as well, ring by
    ring until none is added: the tiles (indices into ``tiles.xg``), their node height changes
    and their LoD.

    A wall built across a slope can leave a tile's template unchanged, and a raised
    platform keeps its flat tiles flat: the category change starts a region, and the
    height change decides how far it reaches. ``compared``: the tiles already compared (those
    whose category differs), as :meth:`MovingTiles.moved` gives them.
    """
    tested, dz, lod, moved = compared
    xg, yg = tiles.xg, tiles.yg
    i = ((xg - xg.min()) // level).astype(np.intp)
    j = ((yg - yg.min()) // level).astype(np.intp)
    index = np.full((j.max() + 3, i.max() + 3), -1, np.intp)  # a border of −1 around the tiles
    index[j + 1, i + 1] = np.arange(len(xg))
    row = np.full(len(xg), -1, np.intp)  # each compared tile's row in the parts below; −2: did not move
    row[tested] = np.where(moved, np.arange(len(tested)), -2)
    row[~valid] = -2
    parts, lods = [dz], [lod]
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
            t, d, lod_t, m = tiles.moved(unknown)
            row[unknown] = -2
            row[t[m]] = count + np.arange(int(m.sum()))
            parts.append(d[m])
            lods.append(lod_t[m])
            count += int(m.sum())
        new = near[row[near] >= 0]
        taken[new] = True
    out = np.flatnonzero(taken)
    return out, np.concatenate(parts)[row[out]], np.concatenate(lods)[row[out]]


def detect(  # noqa: PLR0913 (the two versions, where, how, and the progress)
    db: Database,
    before: str,
    after: str,
    *,
    level: int = 2,
    bbox: tuple[float, float, float, float] | None = None,
    min_tiles: int = 8,
    shift: Shift | None = None,
    progress: Progress | None = None,
    workers: int | None = None,
    unclaimed: list[Unclaimed] | None = None,
) -> list[dict[str, Any]]:
    """Changed regions between ``before`` and ``after`` as GeoJSON feature dicts.

    ``unclaimed``, where given, receives the regions whose surfaces moved but whose change the
    ground evidence does not support (:class:`Unclaimed`), for a user to see what was held back.

    ``shift`` (:func:`queries.coregister.coregister`) aligns ``after`` to ``before`` first, and
    the level of detection is then at least what the residual on stable ground allows. An area
    too wide to read at once is read in parts (:mod:`queries.change_parts`), in ``workers``
    processes (default: one per core); ``progress`` (:mod:`tdb.progress`) follows them.

    Raises
    ------
    CRSError
        If the versions' horizontal coordinate systems differ.
    """
    check_same_horizontal(db.crs(before), db.crs(after), names=(before, after), at=site(db, before))
    lod = level_of_detection(db, before, after, shift=shift)
    parts = parts_for(db, before, level=level, bbox=bbox)
    if not parts:
        return _detect_at_once(
            db,
            before,
            after,
            level=level,
            bbox=bbox,
            min_tiles=min_tiles,
            shift=shift,
            lod=lod,
            unclaimed=unclaimed,
        )
    moved = moved_by_parts(
        db,
        before,
        after,
        level=level,
        bbox=bbox,
        parts=parts,
        lod=lod,
        shift=shift,
        progress=progress,
        workers=workers,
    )
    seeds = np.flatnonzero(moved.differ)
    if len(seeds) == 0:
        return []
    seed_tiles = _Grown.of(moved, seeds)
    strong, weak = _seeds(seed_tiles, level, min_tiles)
    if not strong and not weak:
        return []
    grown = reached(moved.xg, moved.yg, seeds[np.concatenate(strong + weak)], level)
    from_strong = np.isin(grown, seeds[np.concatenate(strong)]) if strong else np.zeros(len(grown), bool)
    t = _Grown.of(moved, grown)
    out = []
    for batch in _batches(_sure_regions(t, from_strong, level, min_tiles), t, level):
        idx = np.concatenate([m for m, *_ in batch])
        lattices = {name: tile_lattice(db, name, level, t.xg[idx], t.yg[idx]) for name in (before, after)}
        if shift is not None and shift.applied:
            lattices[after] = shifted_lattice(lattices[after], shift)
        out += _features(db, (before, after), batch, t, lattices, level=level, unclaimed=unclaimed)
    return out


@dataclass(frozen=True)
class _Grown:
    """Moved tiles (the seeds, or the grown regions): corners, node height changes, LoD and what
    each version's ground evidence says of them."""

    xg: NDArray[np.int64]
    yg: NDArray[np.int64]
    dz: NDArray[np.float64]
    lod: NDArray[np.float64]
    sides: Sides

    @classmethod
    def of(cls, moved: MovedTiles, at: NDArray[np.intp]) -> _Grown:
        """The moved tiles ``at``."""
        return cls(moved.xg[at], moved.yg[at], moved.dz[at], moved.lod[at], moved.sides.take(at))

    @classmethod
    def judged(
        cls, tiles: MovingTiles, at: NDArray[np.intp], dz: NDArray[np.float64], lod: NDArray[np.float64]
    ) -> _Grown:
        """The tiles ``at`` of ``tiles``, their node height changes ``dz`` and LoD ``lod``."""
        return cls(tiles.xg[at], tiles.yg[at], dz, lod, tiles.judged.sides.take(at))


Region = tuple[NDArray[np.intp], float, bool, float]  # members, mean dz, sure, LoD


def _detect_at_once(  # noqa: PLR0913 (the two versions, where, and how)
    db: Database,
    before: str,
    after: str,
    *,
    level: int,
    bbox: tuple[float, float, float, float] | None,
    min_tiles: int,
    shift: Shift | None,
    lod: float,
    unclaimed: list[Unclaimed] | None,
) -> list[dict[str, Any]]:
    xg, yg, c1, c2 = shared_tiles(db, before, after, level=level, bbox=bbox)
    if len(xg) == 0:
        return []
    valid = (c1 != NO_DATA) & (c2 != NO_DATA)
    # Only tiles whose category differs can start a change: the surfaces are rebuilt around them alone.
    differ = np.flatnonzero((c1 != c2) & valid)
    if len(differ) == 0:
        return []
    lattices = {name: tile_lattice(db, name, level, xg[differ], yg[differ]) for name in (before, after)}
    if shift is not None and shift.applied:
        lattices[after] = shifted_lattice(lattices[after], shift)
    tiles = MovingTiles(
        xg, yg, lattices[before], lattices[after], tile_lod(db, before, after, xg, yg, level=level, lod=lod)
    )
    compared = tiles.moved(differ)
    tested, dz, lod_t, moved = compared
    if not moved.any():
        return []
    first = tested[moved]
    seed_tiles = _Grown.judged(tiles, first, dz[moved], lod_t[moved])
    strong, weak = _seeds(seed_tiles, level, min_tiles)
    if not strong and not weak:
        return []
    seeds = first[np.concatenate(strong + weak)]
    grown, dz, lod_t = _grow(tiles, valid, compared, seeds, level)
    from_strong = np.isin(grown, first[np.concatenate(strong)]) if strong else np.zeros(len(grown), bool)
    t = _Grown.judged(tiles, grown, dz, lod_t)
    regions = _sure_regions(t, from_strong, level, min_tiles)
    return _features(db, (before, after), regions, t, lattices, level=level, unclaimed=unclaimed)


def _seeds(t: _Grown, level: int, min_tiles: int) -> tuple[list[NDArray[np.intp]], list[NDArray[np.intp]]]:
    """The regions of the moved tiles whose category differs that grow: strong (large, or a
    strong change), and weak (small; kept at the end only where a closed form came or went)."""
    candidates = _regions(t, level, min_tiles)
    strong = [m for m, _, big, _ in candidates if big]
    weak = [m for m, d, big, at in candidates if not big and abs(d) >= CLOSED_DZ * at]
    return strong, weak


def _sure_regions(t: _Grown, from_strong: NDArray[np.bool_], level: int, min_tiles: int) -> list[Region]:
    """The regions of the grown tiles, each with whether it is sure: where it holds a strong
    seed, or where it is large and moved as a whole by a strong change (a form removed from a
    steep slope changes few categories, so its seeds are weak, but its grown surface still says
    plainly that it moved)."""
    return [
        (members, mean_dz, big and (bool(from_strong[members].any()) or abs(mean_dz) >= STRONG * at), at)
        for members, mean_dz, big, at in _regions(t, level, min_tiles)
        if big or abs(mean_dz) >= CLOSED_DZ * at
    ]


def _batches(regions: list[Region], t: _Grown, level: int) -> list[list[Region]]:
    """The regions in batches, those that start in one part together (:mod:`queries.parts`)."""
    side = part_side(level)
    batches: dict[tuple[int, int], list[Region]] = {}
    for r in regions:
        first = r[0][0]
        batches.setdefault((int(t.xg[first] // side), int(t.yg[first] // side)), []).append(r)
    return [batches[k] for k in sorted(batches)]


def _features(
    db: Database,
    versions: tuple[str, str],
    regions: list[Region],
    t: _Grown,
    lattices: dict[str, NodeLattice],
    *,
    level: int,
    unclaimed: list[Unclaimed] | None = None,
) -> list[dict[str, Any]]:
    """The regions as typed GeoJSON features: those that are sure, or where a closed form came
    or went, and whose change the ground evidence supports (:func:`_doubt`); the others that
    pass the first test go to ``unclaimed`` where it is given."""
    if not regions:
        return []
    before, after = versions
    groups = [m for m, *_ in regions]
    found = {name: _matched(db, name, t.xg, t.yg, groups, level, lattices[name]) for name in versions}
    out = []
    for (members, mean_dz, sure, region_lod), was, now in zip(regions, found[before], found[after]):
        if not sure and not _closed_form_changed(was, now, mean_dz):
            continue
        doubt = _doubt(t, members, mean_dz, region_lod)
        if doubt is not None and unclaimed is None:
            continue
        x, y = t.xg[members], t.yg[members]
        geom = outline(x, y, t.dz[members], t.lod[members], mean_dz, level=level)
        if doubt is not None:
            assert unclaimed is not None  # the regions not claimed are outlined only where asked for
            unclaimed.append(Unclaimed(geom, round(mean_dz, 3), doubt))
            continue
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


class Doubt(StrEnum):
    """Why the ground evidence does not support a region's change (:func:`_doubt`)."""

    LAYER = "under a layer taken for ground"
    SEEN = "seen by the other survey, not taken for ground"
    COVER = "under a cover the survey standing higher did not see through"
    SPARSE = "resting on too few ground returns of one survey"


@dataclass(frozen=True)
class Unclaimed:
    """A region whose surfaces moved but whose change is not claimed: its outline, its mean
    height change (m) and why."""

    geometry: shapely.Geometry
    dz: float
    why: Doubt


def _doubt(t: _Grown, members: NDArray[np.intp], mean_dz: float, lod: float) -> Doubt | None:
    """Why the ground evidence does not support the change of a region (None where it does)."""
    if _resting_on_few(t.sides.returns, members):
        return Doubt.SPARSE
    if _under_a_layer(t.sides.layer, members, mean_dz, lod):
        return Doubt.LAYER
    if _seen_there(t, members, mean_dz, lod):
        return Doubt.SEEN
    if _under_cover(t.sides.pulses, members, mean_dz):
        return Doubt.COVER
    return None


def _resting_on_few(returns: NDArray[np.float64], members: NDArray[np.intp]) -> bool:
    """Whether either version holds fewer than :data:`tdb.evidence.MIN_RETURNS` ground returns over
    a region's tiles (``returns``: 2 × tiles; a version that holds no such evidence there, NaN in
    every tile, is not counted: stored before it was kept).

    Two surveys of under a pulse per m² hold a return in every other 2 m tile or fewer: a region
    of a few tiles between them compares where a handful of returns fell, on each side of a bank
    or a ditch's edge, not how the ground moved."""
    r = returns[:, members]
    counted = np.isfinite(r).any(axis=1)
    return bool((counted & too_few_returns(np.nansum(r, axis=1))).any())


def _under_a_layer(layers: NDArray[np.float64], members: NDArray[np.intp], mean_dz: float, lod: float) -> bool:
    """Whether a region's higher surface (the later one where it rose, the earlier where it fell)
    lies in a layer taken for ground thicker than the level of detection (the median of its
    tiles', ``layers``: 2 × tiles). Under such a layer, vegetation's top, no return of that survey
    reached the ground, and the layer's lift says only how rough its top is, not how far it
    stands over the ground: the survey does not say where the ground was."""
    return bool(np.median(layers[1 if mean_dz > 0 else 0, members]) > lod)


# A region a third of whose tiles the other survey saw at the new level is not claimed: a low wall
# fills about a third of the tiles its change reaches (its own and the flanks either side).
SEEN_SHARE = 1 / 3


def _seen_there(t: _Grown, members: NDArray[np.intp], mean_dz: float, lod: float) -> bool:
    """Whether, over :data:`SEEN_SHARE` of a region's tiles, the version whose surface lies lower
    there (the earlier where it rose) holds returns it did not take for ground at the height the
    other's surface reaches, within the level of detection.

    Where one survey took for ground what the other saw and did not (a low wall, a thicket's top
    over ground seen at a few points), the difference of their surfaces is one of what each took
    for ground. Earth placed or dug leaves no such returns at the new level in the other survey."""
    side = 0 if mean_dz > 0 else 1
    rise = np.nanmax(np.sign(mean_dz) * t.dz[members], axis=1)  # the tile's top: a wall is narrower than it
    low, high = t.sides.over[side, 0, members], t.sides.over[side, 1, members]
    with np.errstate(invalid="ignore"):  # NaN where the survey holds no such return: not seen
        seen = (rise >= low - lod) & (rise <= high + lod)
    return bool(seen.mean() >= SEEN_SHARE)


def _under_cover(pulses: NDArray[np.float64], members: NDArray[np.intp], mean_dz: float) -> bool:
    """Whether the version whose surface stands higher over a region (the later where it rose)
    took for ground less than :data:`tdb.evidence.COVERED` of its pulses there and fewer than
    :data:`tdb.evidence.GROUNDED` per m² (the medians over its tiles; ``pulses``: 2 × 2 × tiles, each
    version's share and pulses per m² taken for ground; tiles holding no such evidence, NaN, do
    not count).

    Under a closed canopy few pulses reach the ground. A dense survey still holds enough of those
    for its filter to find the ground among the understorey's tops; a sparse one does not, and its
    filter takes the understorey's top for the ground: a surface that stands over the ground as
    far as the shrubs rise, rough but with no return under it to show its depth. A fill or a new
    bank left bare has most pulses on it."""
    share, density = pulses[1 if mean_dz > 0 else 0][:, members]
    held = np.isfinite(share) & np.isfinite(density)
    if not held.any():
        return False
    return bool(under_cover(np.median(share[held]), np.median(density[held])))


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
    if not (ratio > CONTOUR).any():
        return shapely.coverage_union_all(shapely.box(xg, yg, xg + level, yg + level))  # tiles never overlap
    x0, y0 = int(xg.min()), int(yg.min())
    ti, tj = (xg - x0) // level, (yg - y0) // level
    fine = _bilinear(_node_grid(ti, tj, ratio), FINE)
    tile = np.zeros((int(tj.max()) + 1, int(ti.max()) + 1), bool)
    tile[tj, ti] = True
    inside = tile[np.arange(fine.shape[0]) // (2 * FINE)][:, np.arange(fine.shape[1]) // (2 * FINE)]
    moved = np.where((fine > CONTOUR) & inside, 0, -1)
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
        rx, ry = split_keys(xg[members] // level, yg[members] // level, level // fine)
        region_owner = np.repeat(owner, (level // fine) ** 2)
        for name, *_ in RULES:
            flt = filters[name]
            if (name, lv) not in runs:
                continue
            found = match_tiles(txg, tyg, code, lat, flt, level=lv, shapes=False)
            tiles = np.concatenate([m.tiles for m in found]) if found else np.zeros(0, np.intp)
            mx, my = split_keys(txg[tiles] // lv, tyg[tiles] // lv, lv // fine)
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
