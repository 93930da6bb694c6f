"""The default ground filter: morphological seeds refined on a gap-filled surface.

1. Low outliers are removed (:mod:`ingest.ground.outliers`).
2. Seeds: the lowest point per cell, opened with growing square windows; a cell
   is an object where the opening removes more than the slope allows for that
   window (the progressive morphological idea of Zhang et al. and SMRF).
3. Refinement: the seed ground becomes a surface posted at the cell corners
   (:func:`ingest.ground.grids.corner_heights`, holes up to 64 m across bridged by straight lines,
   :func:`tdb.fill.fill_lines` then :func:`tdb.fill.fill_nearest`, in later passes only where cells changed,
   :mod:`ingest.ground.refill`) and every point is judged by its height
   above that surface against a threshold that grows with the local slope; the
   ground so found makes the next surface and the test is repeated, which lets
   ground creep up breaks of slope that the square windows cut off.
4. Once settled, ground surfaces a storey over all the ground beside them, behind walls, leave
   it (roofs wider than the largest window, :mod:`ingest.ground.roofs`); then long, narrow, low
   groups of object cells (earthworks,
   :mod:`ingest.ground.earthworks`; grouped as the passes left them and as the
   opening found them) join the ground and the passes go on; once
   settled again, groups that rise smoothly out of the ground (hills,
   :mod:`ingest.ground.hills`) do.
5. Low outliers of step 1 that lie on the settled surface, by the test every point
   passes, rejoin the ground (a lone return under a closed canopy, whose neighbourhood
   is crowns).
6. Free-standing walls join the ground; then ground points that are one-point pits or
   small groups far below all the ground around them (multipath scatter) are dropped again.

The surface used to be a TIN of the ground points. On the ISPRS samples the
gap-filled corner grid is as accurate (3.95 % against 4.02 % mean total error)
and needs no triangulation, which took three quarters of the time.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from ingest.ground.earthworks import EarthworkShape, WallShape, elongated_objects, narrow_walls
from ingest.ground.grids import CellSort, Grid, corner_heights, heights_of, quantised
from ingest.ground.hills import HillShape, point_spacing, smooth_hills
from ingest.ground.morphology import progressive_opening
from ingest.ground.outliers import ground_spikes, low_outliers, point_density, sunken_groups
from ingest.ground.refill import LineFill
from ingest.ground.roofs import RoofShape, raised_roofs
from tdb.bbox import column_range
from tdb.errors import InputError
from tdb.fill import NearestFill, fill_lines, fill_nearest
from tdb.options import GroundStage
from tdb.sort import order_within, scatter_max

# each point's return number and its pulse's number of returns, where known
Returns = tuple[NDArray[np.integer[Any]], NDArray[np.integer[Any]]] | None


@dataclass(frozen=True)
class AutoParams:
    cell: float = 1.0  # seed grid (m)
    envelope_points: float = 16.0  # points per cell of the lower envelope low outliers are judged on
    flat_rejoin: bool = True  # cells the opening took for objects rejoin the surface within threshold alone
    max_window: float = 16.0  # largest opening window radius (m)
    unit_steps_from: float = 8.0  # window radius (m) from which the openings grow one cell at a time
    slope: float = 0.15  # terrain slope the opening tolerates (rise/run)
    threshold: float = 0.3  # height above the ground surface still ground on flat land (m) ...
    threshold_spacings: float = 0.2  # ... plus this much per metre of point spacing
    slope_scale: float = 1.0  # extra threshold per unit of local surface slope
    below: float = 2.0  # points this far below the surface are not ground (m)
    # widest hole (m) the surface bridges by straight lines; a wider one takes the nearest
    # ground, so that what a point is judged against lies within this reach of it
    max_bridge: float = 64.0
    refinements: int = 8  # passes after the first, fewer only where one changes nothing
    stage_passes: int = 1  # refinement passes after each stage below, whatever it found
    pit_window: float = 8.0  # widest low-outlier cluster (m, radius)
    pit_slope: float = 3.0  # pit walls steeper than this, beyond pit_depth, are not terrain
    pit_depth: float = 2.0
    earthworks: EarthworkShape = field(default_factory=EarthworkShape)  # long, narrow, low objects are terrain
    walls: WallShape = field(default_factory=WallShape)  # free-standing walls are terrain; rows of cars are not
    hills: HillShape = field(default_factory=HillShape)  # groups that rise smoothly out of the ground are terrain
    roofs: RoofShape = field(default_factory=RoofShape)  # ground a wall's drop above all around is a roof
    # stages left out, to measure what each earns (benchmarks/ground_stages.py); none by default
    skip: frozenset[GroundStage] = frozenset()


def ground_surface(
    grid: Grid,
    xyz: NDArray[np.float64],
    lowest: NDArray[np.intp],
    *,
    lines: Callable[[NDArray[np.floating[Any]]], NDArray[np.floating[Any]]] = fill_lines,
    nearest: Callable[[NDArray[np.floating[Any]]], NDArray[np.floating[Any]]] = fill_nearest,
) -> tuple[NDArray[np.floating[Any]], NDArray[np.floating[Any]]]:
    """Corner-posted ground surface through the points ``lowest`` (one per cell) with its holes
    filled, and its slope (rise/run), lightly smoothed so one noisy point does not raise the
    threshold around it.

    ``lines`` bridges the holes (:func:`tdb.fill.fill_lines`, or a
    :class:`ingest.ground.refill.LineFill` that a run of passes shares); beyond the data
    the nearest value fills them (``nearest``: :func:`tdb.fill.fill_nearest`, or a
    :class:`tdb.fill.NearestFill` that a run of passes shares).
    """
    surface = nearest(lines(corner_heights(grid, xyz, lowest)))
    dy, dx = np.gradient(ndimage.uniform_filter(surface, size=3, mode="nearest"), grid.cell)
    return surface, np.hypot(dx, dy)


def auto_ground(
    xyz: NDArray[np.float64],
    *,
    params: AutoParams | None = None,
    returns: Returns = None,
    density: float | None = None,
    extent: tuple[float, float, float, float] | None = None,
) -> NDArray[np.bool_]:
    """Ground mask by the default filter (one parameter set for all data).

    Parameters
    ----------
    xyz : (N, 3) coordinates in metres.
    params : thresholds; the defaults are the product's single parameter set.
    returns : (return number, number of returns) of each point. Where some pulse has several
        returns, walls under tree crowns are found from the last returns; without them (or
        where every pulse has one) a wall needs open sky over part of it.
    density : the survey's points per m² (:func:`ingest.ground.outliers.point_density`); None:
        measured on ``xyz``.
    extent : (xmin, ymin, xmax, ymax) the seed grid covers (holding every point); None: the
        points' extent. The grid's empty cells are filled from the nearest data, its edges
        extend the data outward: a part of a survey filtered with its own extent would see
        another edge than the whole survey does, wherever its points end short of its box.
    """
    p = params or AutoParams()
    xyz = np.asarray(xyz, float)
    if returns is not None:
        number, count = (np.asarray(a) for a in returns)
        if number.shape != (len(xyz),) or count.shape != (len(xyz),):
            raise InputError(f"returns need one return number and one count per point ({len(xyz)})")
        returns = (number, count) if (count > 1).any() else None
    ground = np.zeros(len(xyz), bool)
    # One density for the outlier test and the threshold: a block passes the whole survey's.
    density = density or point_density(xyz[:, :2])
    # one order by height serves the cells of every grid below
    by_height = np.argsort(xyz[:, 2], kind="stable")
    outlier = low_outliers(xyz, density=density, envelope_points=p.envelope_points, by_height=by_height)
    keep = np.flatnonzero(~outlier)
    by_height = order_within(by_height, keep, len(xyz))
    # Between sparse points the interpolated surface misses more of the terrain's relief.
    threshold = p.threshold + p.threshold_spacings / np.sqrt(density)
    pts = xyz[keep]
    xy = pts[:, :2]
    grid = Grid.covering(xy if extent is None else np.array([extent[:2], extent[2:], *column_range(xy)]), p.cell)
    cells = CellSort.of(grid, pts, by_height=by_height)
    idx = cells.lowest()
    zmin = heights_of(idx, pts)
    objects = progressive_opening(
        zmin, cell=p.cell, max_window=p.max_window, slope=p.slope, unit_steps_from=p.unit_steps_from
    )
    pits = _pits(zmin, p)
    current = np.where(~objects & ~pits, idx, -1)
    at_points = grid.corner_sampler(pts[:, :2])
    # A cell the opening took for an object holds ground only where its point lies on the
    # surface beside it; with the slope's allowance too, the surface climbed a thicket's top
    # one band per pass, as it climbs a steep flank.
    rejoin = ~objects[grid.index(pts[:, :2])] if p.flat_rejoin else np.ones(len(pts), bool)
    # later passes change few cells of the surface: only their runs of holes are filled again
    lines, nearest = LineFill(max_gap=p.max_bridge / p.cell), NearestFill()
    # Once the passes are done, each stage may change their ground, once: roofs too wide for
    # the openings leave it; steep-sided ridges, dikes and embankment crests (long, narrow, low
    # groups of object cells), then hills (groups that rise smoothly out of the ground) join it.
    stages = [s for s in (GroundStage.ROOFS, GroundStage.EARTHWORKS, GroundStage.HILLS) if s not in p.skip]
    on_roof = np.zeros(len(pts), bool)
    group_cell = _group_cell(pts, p)  # the roofs' and the hills' grid
    passes = p.refinements + 1
    while True:
        passes -= 1
        surface, slope_map = ground_surface(grid, pts, current, lines=lines, nearest=nearest)
        h = pts[:, 2] - at_points(surface)
        is_ground = _accepted(h, at_points(slope_map), threshold, p) & ~on_roof
        # The next surface rests on the lowest ground point per cell: noise and
        # low clutter among the accepted points would otherwise lift it.
        before, current = current, cells.lowest(is_ground & (rejoin | (h <= threshold)))
        # All the passes, stopped early only at a fixed point (where more would repeat this one):
        # a stop once few labels change, counted over the survey, ended a block and the whole
        # survey after different passes.
        if passes > 0 and not np.array_equal(before, current):
            continue
        if not stages:
            break
        # Every stage is followed by its passes, whatever it found: where the ground still creeps up
        # a flank, one pass more moves it, and a count that hung on a stage finding something
        # anywhere in the survey ended a block and the whole survey after different passes.
        stage = stages.pop(0)
        if stage is GroundStage.ROOFS:
            on_roof = raised_roofs(pts, is_ground, cell=group_cell, shape=p.roofs)
            is_ground &= ~on_roof
            current = np.where((current >= 0) & on_roof[np.maximum(current, 0)], -1, current)
        else:
            found = (
                _earthworks(grid, surface, zmin, idx, current, objects & ~pits, p)
                if stage is GroundStage.EARTHWORKS
                else _hills(grid, pts, is_ground, group_cell, p, by_height)
            )
            current = np.where(found, idx, current)
        passes = p.stage_passes
    if GroundStage.REJOIN not in p.skip:
        back, h_back = _rejoined(grid, xyz[outlier], surface, slope_map, threshold, p)
        if len(back):
            keep = np.r_[keep, np.flatnonzero(outlier)[back]]
            h, is_ground = np.r_[h, h_back], np.r_[is_ground, np.ones(len(back), bool)]
            pts = xyz[keep]
            cells = CellSort.of(grid, pts)
    kept_returns = None if returns is None else (returns[0][keep], returns[1][keep])
    ground[keep[_last_stages(grid, cells, pts, h, is_ground, p, kept_returns)]] = True
    return ground


def _rejoined(
    grid: Grid,
    outliers: NDArray[np.float64],
    surface: NDArray[np.floating[Any]],
    slope: NDArray[np.floating[Any]],
    threshold: float,
    p: AutoParams,
) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
    """Which of the low ``outliers`` (their coordinates) lie on the settled ``surface``, and their
    heights above it.

    An outlier by its neighbourhood that passes the test every point passes is ground: under a
    canopy few pulses get through, and a lone ground return's neighbourhood is crowns. It joins
    before the last stages, so that a one-point pit still leaves."""
    at = grid.corner_sampler(outliers[:, :2])
    h = outliers[:, 2] - at(surface)
    on = np.flatnonzero(_accepted(h, at(slope), threshold, p))
    return on, h[on]


def _accepted(
    h: NDArray[np.float64], slope: NDArray[np.float64], threshold: float, p: AutoParams
) -> NDArray[np.bool_]:
    """Whether points ``h`` m above the ground surface, where it rises by ``slope``, are ground."""
    return (h <= threshold + p.slope_scale * slope) & (h >= -p.below)


def _pits(zmin: NDArray[np.float64], p: AutoParams) -> NDArray[np.bool_]:
    """Cells of deep narrow pits: clusters of low outliers too big for the neighbour test, found
    by the opening of the upside-down surface."""
    if GroundStage.PITS in p.skip:
        return np.zeros(zmin.shape, bool)
    return progressive_opening(-zmin, cell=p.cell, max_window=p.pit_window, slope=p.pit_slope, offset=p.pit_depth)


def _last_stages(
    grid: Grid,
    cells: CellSort,
    pts: NDArray[np.float64],
    h: NDArray[np.float64],
    is_ground: NDArray[np.bool_],
    p: AutoParams,
    returns: Returns,
) -> NDArray[np.bool_]:
    """The ground once the passes are settled: free-standing walls join it, one-point pits and
    multipath scatter leave it (each unless ``p.skip`` names it)."""
    if GroundStage.WALLS not in p.skip:
        is_ground = is_ground | _walls(grid, pts, h, is_ground, p, returns)
    # One point 1-3 m under all the ground around it passed the 3 m outlier test; it is no terrain.
    if GroundStage.SPIKES not in p.skip:
        is_ground = is_ground & ~ground_spikes(pts, is_ground, cells=cells)
    # Multipath scatter under a void, tens of metres down: groups no other test takes.
    if GroundStage.SUNKEN not in p.skip:
        is_ground = is_ground & ~sunken_groups(pts, is_ground, cells=cells)
    return is_ground


def _walls(
    grid: Grid,
    pts: NDArray[np.float64],
    h: NDArray[np.float64],
    is_ground: NDArray[np.bool_],
    p: AutoParams,
    returns: Returns,
) -> NDArray[np.bool_]:
    """Points of free-standing walls (:func:`ingest.ground.earthworks.narrow_walls`), from each
    point's height ``h`` above the settled ground surface and, where known, each point's return
    number and its pulse's number of returns."""
    low = ~is_ground & (h > p.walls.least_height) & (h <= p.walls.max_height)
    row, col = grid.index(pts[:, :2])
    higher = h > p.walls.max_height
    tall = np.zeros(grid.shape, bool)
    hidden = None
    if returns is None:
        # Cells with a point higher than any wall: roofs or crowns; both the band beside a building
        # and a band under trees have them close by, and leaves among a band's points are no wall's top.
        tall[row[higher], col[higher]] = True
    else:
        # A crown lets pulses through to the wall under it, a roof does not: a wall's top is a last
        # return, and only cells whose high points are mostly last returns are roofs.
        number, count = returns
        last = number >= count
        low &= last
        flat = row * grid.shape[1] + col
        high = np.bincount(flat[higher], minlength=tall.size)
        solid = np.bincount(flat[higher & last], minlength=tall.size)
        tall = (2 * solid > high).reshape(grid.shape)
        hidden = np.zeros(grid.shape, bool)
    band = np.zeros(grid.shape, bool)
    band[row[low], col[low]] = True
    top = np.zeros(grid.shape)
    scatter_max(top, row[low] * grid.shape[1] + col[low], h[low])
    walls = narrow_walls(
        band,
        top,
        tall,
        cell=grid.cell,
        hidden=hidden,
        shape=p.walls,
    )
    # NaN (no wall) compares False; points well above a wall's top are leaves over it.
    return low & (h <= walls[row, col] + p.walls.above_top)


def _group_cell(pts: NDArray[np.float64], p: AutoParams) -> float:
    """Cell size (m) of the grids the hills and roofs are grouped on: about 1.5 point spacings,
    so that sparse data leaves few cells empty."""
    return max(p.cell, quantised(p.hills.spacings * point_spacing(pts[:, :2])))


def _hills(
    grid: Grid,
    pts: NDArray[np.float64],
    is_ground: NDArray[np.bool_],
    cell: float,
    p: AutoParams,
    by_height: NDArray[np.intp],
) -> NDArray[np.bool_]:
    """Cells of ``grid`` whose lowest point is the lowest of a hill's cell of ``cell`` m
    (:func:`ingest.ground.hills.smooth_hills`); ``by_height``: the points' stable order by height."""
    found = np.flatnonzero(smooth_hills(pts, is_ground, cell=cell, shape=p.hills, by_height=by_height))
    out = np.zeros(grid.shape, bool)
    out[grid.index(pts[found, :2])] = True
    return out


def _earthworks(
    grid: Grid,
    surface: NDArray[np.floating[Any]],
    zmin: NDArray[np.float64],
    lowest: NDArray[np.intp],
    current: NDArray[np.intp],
    seeds: NDArray[np.bool_],
    p: AutoParams,
) -> NDArray[np.bool_]:
    """Cells of long, narrow, low objects (:func:`ingest.ground.earthworks.elongated_objects`),
    among the cells whose lowest point is not ground."""
    objects = (lowest >= 0) & (current != lowest)
    centre = 0.25 * (surface[:-1, :-1] + surface[1:, :-1] + surface[1:, 1:] + surface[:-1, 1:])

    def elongated(cells: NDArray[np.bool_]) -> NDArray[np.bool_]:
        return elongated_objects(
            cells,
            np.where(cells, zmin - centre, 0.0),
            cell=grid.cell,
            shape=p.earthworks,
        )

    # The passes creep up a steep ridge here and there and leave its top cut in short pieces,
    # too short to pass, and not the same pieces in two surveys; the ridge was whole among the
    # cells the opening took for objects (``seeds``), so those groups are judged too.
    return objects & (elongated(objects) | elongated(seeds))
