"""Vegetation or building (seed §2.2): texture of the highest returns, then the roof check.

The highest point of each cell more than ``min_height`` over the ground is classified by
the median-filtered texture of the height raster (:mod:`ingest.objects.texture`), with a
two-class mixture fitted to the survey (:mod:`ingest.objects.mixture`). Every region the
texture calls building is then checked as the paper checks the small ones: inside its
border a roof's returns lie close to their local plane (the paper's small unfiltered second
derivative, taken at the points' true positions) and few are double echoes. Checking the
large regions too costs nothing and keeps a smooth forest canopy, where the smoother of the
two texture classes is itself vegetation, from being called a roof.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from ingest.ground.grids import Grid, quantised
from ingest.ground.hills import point_spacing
from ingest.objects.climb import NEIGHBOURS
from ingest.objects.heights import TopRaster, above_ground, flat_cells
from ingest.objects.mixture import fit_two
from ingest.objects.texture import median_texture
from tdb.cloud import (
    BUILDING,
    GROUND,
    HIGH_NOISE,
    HIGH_VEGETATION,
    LOW_VEGETATION,
    MEDIUM_VEGETATION,
    OTHER,
    PointCloud,
)
from tdb.errors import TdbWarning
from tdb.fill import fill_nearest
from tdb.kdtree import plan_tree
from tdb.median import median_filter
from tdb.raster import Raster

VEGETATION_CELL, BUILDING_CELL = 1, 2
MIN_CELL = 0.25  # m: the finest texture cell, whatever the density
MIN_CELLS_TO_FIT = 20  # fewer tall cells than this are all vegetation: no mixture to fit
SINGLE_RETURNS = "single returns only, so buildings are told from vegetation without the double-echo test"
_EPS = 1e-3  # m: keeps the logarithm of a perfectly plane roof finite


@dataclass(frozen=True)
class CoverParams:
    """How points over the ground are told apart.

    ``min_height`` (m): cells whose highest point is this far over the ground are classified
    (the paper's 2 m). ``cell_spacings``: texture cell size in pulse spacings (1.5: nine in
    ten cells hold a pulse). ``roof_departure`` (m): the largest median departure of a roof's
    returns inside its border from their local plane, through the neighbours on whichever
    side fit one best (:meth:`TopRaster.plane_departure`): a roof plane departs only by the
    returns' noise, a crown by decimetres to metres.
    ``eave_tolerance`` (m): an edge cell whose highest return lies this close to the line
    through the two roof cells behind it is roof (the raster's error on a steep roof, slope
    × half a cell, is up to half a metre).
    ``echo_share``: the largest share of a roof's returns inside its border that come from
    pulses with more than one return. ``min_building_area`` (m²): a smaller region is not a
    building. ``low_height``, ``high_height`` (m): vegetation under ``low_height`` is class 1
    (near the ground), up to ``min_height`` class 3, up to ``high_height`` class 4, above it 5.
    ``max_height`` (m): a return higher over the ground is high noise (class 18: a bird, a
    cloud, dust), no object: taller than the tallest trees (about 115 m), it would otherwise
    stand in a canopy cell for the crown under it. Towers and buildings that stand higher are
    left out with it; raise it for a city of skyscrapers.
    """

    min_height: float = 2.0
    cell_spacings: float = 1.5
    roof_departure: float = 0.1
    eave_tolerance: float = 0.5
    echo_share: float = 0.2
    min_building_area: float = 10.0
    low_height: float = 0.5
    high_height: float = 5.0
    max_height: float = 150.0


@dataclass(frozen=True)
class Cover:
    """Classes per point (ASPRS codes) and per cell, and each point's height over the ground.

    ``top`` is the texture raster's highest point per cell, ``point_cell`` each point's flat
    cell on it; ``cells`` (its rows, south to north): 0 low or empty, 1 vegetation, 2 building.
    ``spacing``: the pulses' mean spacing (m).
    ``echo_test`` is false where the survey has single returns only, so no double-echo test ran.
    """

    classes: NDArray[np.uint8]
    height: NDArray[np.float64]
    top: TopRaster
    point_cell: NDArray[np.intp]
    cells: NDArray[np.uint8]
    echo_test: bool
    spacing: float


def pulse_spacing(cloud: PointCloud) -> float:
    """The mean spacing (m) of the pulses (first returns)."""
    first = cloud.return_number <= 1
    return point_spacing(cloud.xyz[first, :2] if first.sum() >= 3 else cloud.xyz[:, :2])


TWIN_PLAN = 0.02  # m: a pulse's first and last return this close in plan are one place ...
TWIN_HEIGHT = 0.5  # m: ... and this close in height one echo: under any sensor's range resolution


def separate_echoes(cloud: PointCloud) -> NDArray[np.bool_]:
    """The returns of pulses that gave more than one echo: those of multi-return pulses, less
    the returns recorded twice, as first and last of a pulse that met one surface (within
    :data:`TWIN_PLAN` in plan and :data:`TWIN_HEIGHT` in height of another multi-return point).
    Surveys delivered as first and last pulse (the ISPRS site clouds) give every pulse two
    returns, on a roof at one place; counting those as double echoes made every roof a crown."""
    multi = cloud.number_of_returns > 1
    at = np.flatnonzero(multi)
    if len(at) < 2:
        return multi
    pairs = plan_tree(cloud.xyz[at, :2]).query_pairs(TWIN_PLAN, output_type="ndarray")
    a, b = at[pairs[:, 0]], at[pairs[:, 1]]
    once = np.abs(cloud.xyz[a, 2] - cloud.xyz[b, 2]) <= TWIN_HEIGHT
    multi[a[once]] = False
    multi[b[once]] = False
    return multi


def cell_size(spacing: float, *, spacings: float) -> float:
    """A raster cell (m) of ``spacings`` pulse spacings, on the quarter-octave ladder."""
    return max(MIN_CELL, quantised(spacings * spacing))


def classify_cover(
    cloud: PointCloud,
    ground: NDArray[np.bool_],
    dtm: Raster,
    *,
    params: CoverParams | None = None,
    skip: NDArray[np.bool_] | None = None,
) -> Cover:
    """Classify every point: ground (2), vegetation by height (3, 4, 5), building (6), other (1),
    high noise (18).

    Parameters
    ----------
    cloud : the survey in metres.
    ground : mask of its ground points.
    dtm : its dense ground model.
    params : see :class:`CoverParams`.
    skip : points that are no object (noise): they keep their class, and their height is NaN.
    """
    p = params or CoverParams()
    h = above_ground(cloud.xyz, dtm)
    high = np.nan_to_num(h, nan=-np.inf) > p.max_height
    h[high] = np.nan
    if skip is not None:
        h[skip] = np.nan
    spacing = pulse_spacing(cloud)
    grid = Grid.covering(cloud.xyz[:, :2], cell_size(spacing, spacings=p.cell_spacings))
    cell = flat_cells(grid, cloud.xyz[:, :2])
    top = TopRaster.of(grid, cloud.xyz[:, :2], h, cells=cell)
    multi = separate_echoes(cloud)
    echo_test = bool(multi.any())
    if not echo_test:
        warnings.warn(f"{cloud.source}: {SINGLE_RETURNS}", TdbWarning, stacklevel=2)
    tall = np.nan_to_num(h, nan=-np.inf) > p.min_height
    cells = _cell_classes(top, cloud.xyz[:, :2], p, _Echoes(cell, tall, multi & tall) if echo_test else None)
    classes = _point_classes(h, ground, cells.ravel()[cell], p)
    classes[high] = HIGH_NOISE
    if skip is not None:
        classes[skip] = cloud.classification[skip]
    return Cover(classes, h, top, cell, cells, echo_test, spacing)


@dataclass(frozen=True)
class _Echoes:
    """Each point's cell, whether it is over ``min_height``, and whether it is so and one of
    several returns of its pulse."""

    cell: NDArray[np.intp]
    tall: NDArray[np.bool_]
    double: NDArray[np.bool_]

    def shares(self, judged: NDArray[np.bool_], labels: NDArray[np.intp], n: int) -> NDArray[np.float64]:
        """Per region, the share of its tall returns in ``judged`` cells that are double echoes."""
        keep = judged.ravel()[self.cell] & self.tall
        lab = labels.ravel()[self.cell[keep]]
        returns = np.bincount(lab, minlength=n + 1)
        doubles = np.bincount(lab, weights=self.double[keep], minlength=n + 1)
        return doubles / np.maximum(returns, 1)


def _cell_classes(
    top: TopRaster, xy: NDArray[np.float64], p: CoverParams, echoes: _Echoes | None
) -> NDArray[np.uint8]:
    tall = np.nan_to_num(top.height, nan=-np.inf) > p.min_height
    out = np.where(tall, VEGETATION_CELL, 0).astype(np.uint8)
    if tall.sum() < MIN_CELLS_TO_FIT:
        return out
    # the texture and the eaves read z two cells round a tall cell, the roof test the plane one
    near = ndimage.binary_dilation(tall, np.ones((3, 3), bool))
    z = np.asarray(
        fill_nearest(
            np.where(np.isfinite(top.height), np.maximum(top.height, 0.0), np.nan),
            where=ndimage.binary_dilation(near, np.ones((3, 3), bool)),
        ),
        float,
    )
    plane = np.asarray(fill_nearest(np.where(tall, top.plane_departure(xy, tall), np.nan), where=near), float)
    texture = median_texture(z, top.grid.cell)[tall]
    features = np.log(texture + _EPS)
    smooth = fit_two(features).classify(features) == 0
    if echoes is not None:
        # A steep roof is as steep as a crown and, at a coarse cell, as rough in the raster: the
        # mixture may class it rough. Where its points lie on a plane it is a roof candidate
        # too, since the double echoes still tell a smooth crown from a roof; without them the
        # candidates are the mixture's alone.
        smooth |= median_filter(plane, 3, mode="nearest")[tall] <= p.roof_departure
    roof = np.zeros(tall.shape, bool)
    roof[tall] = smooth
    roof &= _roofs(roof, plane, top.grid.cell, p, echoes)
    out[_roof_edges(roof, z, tall, p.eave_tolerance)] = BUILDING_CELL
    return out


def _roof_edges(
    roof: NDArray[np.bool_], z: NDArray[np.float64], tall: NDArray[np.bool_], departure: float, *, passes: int = 2
) -> NDArray[np.bool_]:
    """The roofs grown by the cells at their edges whose highest return continues a roof's plane.

    The median filter calls a roof's edge cells rough (each holds the edge's drop), so a roof
    region stops short of its eaves. An edge cell whose highest return lies, within
    ``departure``, on the line through the two roof cells behind it is roof.
    """
    grown = roof.copy()
    for _ in range(passes):
        add = np.zeros_like(grown)
        for dr, dc in NEIGHBOURS:
            one, two = _shift(grown, dr, dc, False), _shift(grown, 2 * dr, 2 * dc, False)
            predicted = 2 * _shift(z, dr, dc, np.nan) - _shift(z, 2 * dr, 2 * dc, np.nan)
            add |= one & two & (np.abs(z - predicted) <= departure)
        add &= tall & ~grown
        if not add.any():
            break
        grown |= add
    return grown


def _shift(a: NDArray, dr: int, dc: int, fill: object) -> NDArray:
    """``a`` seen from each cell's neighbour at (dr, dc): out[i, j] = a[i + dr, j + dc]."""
    out = np.full_like(a, fill)
    rows, cols = a.shape
    rs = slice(max(0, -dr), rows - max(0, dr))
    cs = slice(max(0, -dc), cols - max(0, dc))
    rd = slice(max(0, dr), rows - max(0, -dr))
    cd = slice(max(0, dc), cols - max(0, -dc))
    out[rs, cs] = a[rd, cd]
    return out


def _roofs(
    candidate: NDArray[np.bool_],
    plane: NDArray[np.float64],
    cell: float,
    p: CoverParams,
    echoes: _Echoes | None,
) -> NDArray[np.bool_]:
    """Cells of the candidate regions that pass the roof check."""
    labels, n = ndimage.label(candidate, structure=np.ones((3, 3)))
    if n == 0:
        return candidate
    inside = ndimage.binary_erosion(candidate, structure=np.ones((3, 3)))
    # A region too narrow to have an inside is judged on all its cells.
    has_inside = np.bincount(labels[inside], minlength=n + 1) > 0
    judged = np.where(has_inside[labels], inside, candidate) & (labels > 0)
    lab = labels[judged]
    count = np.bincount(lab, minlength=n + 1)
    departure = np.full(n + 1, np.inf)
    have = np.flatnonzero(count > 0)
    departure[have] = ndimage.median(plane, labels=np.where(judged, labels, 0), index=have)
    area = np.bincount(labels.ravel(), minlength=n + 1) * cell**2
    ok = (departure <= p.roof_departure) & (area >= p.min_building_area)
    if echoes is not None:
        ok &= echoes.shares(judged, labels, n) <= p.echo_share
    ok[0] = False
    return ok[labels]


def _point_classes(
    h: NDArray[np.float64], ground: NDArray[np.bool_], cell_class: NDArray[np.uint8], p: CoverParams
) -> NDArray[np.uint8]:
    out = np.full(len(h), OTHER, np.uint8)
    hh = np.nan_to_num(h, nan=-np.inf)
    vegetation = cell_class != BUILDING_CELL
    out[vegetation & (hh >= p.low_height)] = LOW_VEGETATION
    out[vegetation & (hh >= p.min_height)] = MEDIUM_VEGETATION
    out[vegetation & (hh >= p.high_height)] = HIGH_VEGETATION
    out[(cell_class == BUILDING_CELL) & (hh >= p.min_height)] = BUILDING
    out[ground] = GROUND
    return out
