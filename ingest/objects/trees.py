"""Individual trees (seed §2.3): a crown model, smoothing at three scales, climbing, and
the scale chosen per crown.

The canopy model is the highest vegetation return per cell with the penetrations removed
by the active contour of the ground filter applied from above: returns deeper than
``penetration`` under the crown surface do not attract the net. It is smoothed at three
scales; on each, every vegetation cell climbs to its local maximum (:mod:`climb`), and
the scales are combined crown by crown by paraboloid fits (:mod:`crowns`), whose crossings then
place the boundaries between crowns (:mod:`crown_envelope`). Each segment is
a tree: its highest return gives the position, and the height less the shortfall of a
crown's highest return below its top (:mod:`apex`, measured on the survey), its area or its free
edge the crown diameter (:mod:`crown_size`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from ingest.ground.contour import ContourParams, relax_on
from ingest.ground.grids import Grid
from ingest.objects.apex import crown_shortfalls
from ingest.objects.climb import climb
from ingest.objects.cover import Cover, cell_size
from ingest.objects.crown_envelope import crossed_boundaries
from ingest.objects.crown_size import crown_diameters, under_base
from ingest.objects.crowns import choose_scales
from ingest.objects.heights import TopRaster, flat_cells
from tdb.cloud import HIGH_VEGETATION, MEDIUM_VEGETATION, PointCloud
from tdb.fill import fill_nearest, nearest_adjacent
from tdb.objects import Tree
from tdb.outlines import outlines

# The crown net's pull in its first phase: its own, as the tree settings were chosen with it,
# not the ground filter's gravitation, which is chosen on the ground.
CROWN_NET_GRAVITY = 0.5


@dataclass(frozen=True)
class TreeParams:
    """How trees are found.

    ``scales`` (m): the Gaussian smoothing radii, finest first; the finest splits most large
    crowns, the coarsest splits none. ``cell_spacings``: canopy cell in pulse spacings.
    ``penetration`` (m): the contour's attraction range under the crown surface.
    ``iterations``: at most this many contour steps per phase. ``hole_spacings``: the widest
    penetration (a hole with crown all round it) in pulse spacings; the contour's lift elsewhere,
    at the foot of a taller crown's edge, is undone (:func:`crown_surface`; None: never).
    ``noise`` (m): the canopy model's noise, the floor of the paraboloids' residuals.
    ``min_crown_area`` (m²): a smaller segment is not a tree. ``crown_base``: a crown's cells lie
    above this share of its top's height; lower cells of its segment are a lower crown's edge that
    it captured (:func:`ingest.objects.crown_size.under_base`; None: every cell).
    ``crossing_area`` (m²): crowns at least this large move their boundaries to where their
    paraboloids cross (:mod:`ingest.objects.crown_envelope`; None: the boundaries as climbed).
    The scales, the noise and the hole width were chosen by leave-one-group-out cross-validation
    (``benchmarks/objects_cv.py``), the crown base and the crossing's area the same way on the
    crown diameter (``benchmarks/crown_cv.py``).
    """

    scales: tuple[float, ...] = (0.35, 0.7, 1.4)
    cell_spacings: float = 1.0
    penetration: float = 1.5
    iterations: int = 30
    noise: float = 0.4
    min_crown_area: float = 2.0
    hole_spacings: float | None = 4.0
    crown_base: float | None = 0.4
    crossing_area: float | None = 8.0


def find_trees(cloud: PointCloud, cover: Cover, *, params: TreeParams | None = None) -> list[Tree]:
    """The trees of a classified survey (points of classes 4 and 5), largest first.

    Parameters
    ----------
    cloud : the survey in metres.
    cover : its classes and heights (:func:`ingest.objects.classify_cover`).
    params : see :class:`TreeParams`.
    """
    p = params or TreeParams()
    tall = np.isin(cover.classes, (MEDIUM_VEGETATION, HIGH_VEGETATION))
    if tall.sum() < 3:
        return []
    grid = Grid.covering(cloud.xyz[tall, :2], cell_size(cover.spacing, spacings=p.cell_spacings))
    near = _inside(grid, cloud.xyz[:, :2]) & np.isfinite(cover.height)
    cell = flat_cells(grid, cloud.xyz[:, :2])
    filled = np.bincount(cell[near], minlength=grid.shape[0] * grid.shape[1]) > 0
    # A cell's highest return is a crown's only where some return there stands as high as the
    # crowns' returns do: the rasters are made of those (most returns are lower), the rest
    # only fill their cells.
    high = np.flatnonzero(near & (cover.height >= cover.height[tall].min()))
    xyz, cells = cloud.xyz[high], cell[high]
    top = TopRaster.of(grid, xyz[:, :2], cover.height[high], cells=cells)
    mask = _crown_cells(top, tall[high], filled.reshape(grid.shape))
    canopy = crown_surface(np.where(mask, top.height, np.nan), mask, grid.cell, params=p)
    scales = [climb(smoothed(canopy, mask, s / grid.cell), mask) for s in sorted(p.scales, reverse=True)]
    min_cells = max(1, int(np.ceil(p.min_crown_area / grid.cell**2)))
    labels = choose_scales(scales, canopy, grid.cell, noise=p.noise, min_cells=min_cells)
    if p.crossing_area is not None:
        labels = crossed_boundaries(labels, canopy, grid.cell, min_area=p.crossing_area)
    crown = np.where(tall[high], labels.ravel()[cells], -1)
    shortfall = crown_shortfalls(crown, cover.height[high], xyz[:, :2], n=int(labels.max()) + 1)
    return _measure(labels, under_base(labels, canopy, p.crown_base), top, xyz, min_cells, shortfall)


def _inside(grid: Grid, xy: NDArray[np.float64]) -> NDArray[np.bool_]:
    x1 = grid.x0 + grid.shape[1] * grid.cell
    y1 = grid.y0 + grid.shape[0] * grid.cell
    return (xy[:, 0] >= grid.x0) & (xy[:, 0] < x1) & (xy[:, 1] >= grid.y0) & (xy[:, 1] < y1)


def _crown_cells(top: TopRaster, tall: NDArray[np.bool_], filled: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Cells whose highest return is a tree's; an empty cell beside a filled one (within 1.5
    cells: one of its 8 neighbours) takes the nearest filled cell's answer, so a crown's edge
    falls between its last return and the first beside it instead of shrinking by the empty
    cells along it. Farther from any return (outside the survey, in its gaps) a cell is no
    crown. ``filled``: the cells holding a return (of any height)."""
    answer = np.where(top.index >= 0, tall[np.maximum(top.index, 0)], False)
    if filled.all() or not filled.any():
        return answer
    near = nearest_adjacent(filled)  # within 1.5 cells: the cell itself or one of its 8 neighbours
    return (near >= 0) & answer.ravel()[np.maximum(near, 0)].reshape(filled.shape)


def crown_surface(
    height: NDArray[np.float64], mask: NDArray[np.bool_], cell: float, *, params: TreeParams
) -> NDArray[np.float64]:
    """The outer crown surface: the active contour relaxed onto the highest returns from above.

    The net starts on the data, an empty cell (NaN) at its nearest return, so that every cell
    begins within its return's attraction: elasticity then lifts the net out of the
    penetrations, and empty cells, which have no attraction, follow their neighbours. A net
    started at the highest of each cell's neighbours began, beside a taller crown, metres
    above a lower crown's returns, out of their reach, and bridged the two crowns. Only the
    crowns' cells (``mask``) move: the gaps between crowns are no part of a crown.

    The net also spans a step, where a lower crown meets a taller one's edge: it lifts the lower
    crown's returns beside the step as it lifts penetrations, and the lower crown then climbs
    into the taller one. A penetration is a hole with crown all round it; a grey closing fills
    holes up to ``hole_spacings`` wide to their rim and leaves a step as it is, so the net is
    kept only as far up as the closing reaches.
    """
    start = np.asarray(fill_nearest(height), np.float64)
    contour = ContourParams(max_iterations=params.iterations, gravity=CROWN_NET_GRAVITY)
    relaxed = -relax_on(-height, -start, mask, cell, params.penetration, contour)
    if params.hole_spacings is None:
        return relaxed
    return np.minimum(relaxed, filled_holes(start, params.hole_spacings / params.cell_spacings))


def filled_holes(surface: NDArray[np.float64], width: float) -> NDArray[np.float64]:
    """``surface`` with every hole narrower than ``width`` cells filled to its rim: a grey
    closing whose square is one cell wider (odd), which leaves a step as it is."""
    side = 2 * int(np.ceil(width / 2)) + 1
    return np.asarray(ndimage.grey_closing(surface, size=(side, side), mode="nearest"), np.float64)


def smoothed(surface: NDArray[np.float64], mask: NDArray[np.bool_], sigma: float) -> NDArray[np.float64]:
    """Gaussian smoothing (``sigma`` in cells) of the crowns with the ground, height 0, around
    them: a crown's edge then falls towards the ground as the crown does, where smoothing the
    crowns alone would raise false maxima along their edges."""
    return np.where(mask, ndimage.gaussian_filter(np.where(mask, surface, 0.0), sigma, mode="constant"), -np.inf)


def _measure(
    labels: NDArray[np.intp],
    crowns: NDArray[np.intp],
    top: TopRaster,
    xyz: NDArray[np.float64],
    min_cells: int,
    shortfall: NDArray[np.float64],
) -> list[Tree]:
    """The trees of the segments ``labels``: each one's highest return, raised by its crown's
    ``shortfall`` (:func:`crown_shortfalls`, by segment), its crown (the segment's outline), and
    the diameter of the segment's cells above its base (``crowns``, :func:`under_base`).

    The outline stays the segment's: change detection asks whether a later crown covers a tree's
    top, and the top of a lower tree whose edge a taller crown captured lies under that capture."""
    on = (labels >= 0) & (top.index >= 0)
    n = int(labels.max()) + 1 if (labels >= 0).any() else 0
    if n == 0:
        return []
    cells = np.bincount(labels[labels >= 0], minlength=n)
    lab, h, idx = labels[on], top.height[on], top.index[on]
    order = np.lexsort((h, lab))
    last = np.r_[lab[order][1:] != lab[order][:-1], True]
    best = np.full(n, -1, np.intp)
    best[lab[order][last]] = idx[order][last]
    height = np.full(n, np.nan)
    height[lab[order][last]] = h[order][last]
    height += shortfall
    keep = (cells >= min_cells) & (best >= 0)
    g = top.grid
    shapes = outlines(
        np.where(keep[np.maximum(labels, 0)] & (labels >= 0), labels, -1), x0=g.x0, y0=g.y0, cell=g.cell
    )
    diameter = crown_diameters(crowns, top.grid.cell)
    trees = [
        Tree(
            float(xyz[best[k], 0]),
            float(xyz[best[k], 1]),
            float(height[k]),
            float(diameter[k]),
            shapes[int(k)],
        )
        for k in np.flatnonzero(keep)
    ]
    return sorted(trees, key=lambda t: -t.height)
