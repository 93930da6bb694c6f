"""Buildings as footprints: the object form of the roof regions.

A roof region's outline on the texture raster is off by up to a cell. The footprint is
drawn instead where the nearest return is a roof return of that building, on a raster
``refine`` times finer: the edge then falls half-way between the last roof return and the
first return beside it, whatever the density, over the cells within :data:`REACH` texture
cells of the region; beyond them is no building's (a void beside a roof is no part of it).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from scipy.spatial import cKDTree

from ingest.ground.grids import Grid
from ingest.objects.cover import BUILDING_CELL, Cover
from ingest.objects.walls import fit_walls
from tdb.cloud import BUILDING
from tdb.kdtree import plan_tree
from tdb.objects import Building
from tdb.outlines import outlines

REACH = 1  # texture cells: how far from a region's outline its footprint's edge may fall
ROOF_TOP = 0.98  # quantile of the roof returns' heights taken as the roof's top (not an antenna)


@dataclass(frozen=True)
class FootprintParams:
    """``refine``: footprint cells per texture cell, across; ``walls``: fit the outline wall by
    wall (:mod:`ingest.objects.walls`), at the texture cell's resolution; ``simplify`` (texture
    cells): the largest departure of an outline not so fitted, after simplification."""

    refine: int = 4
    walls: bool = True
    simplify: float = 0.5


def find_buildings(
    xyz: NDArray[np.float64], cover: Cover, *, params: FootprintParams | None = None
) -> list[Building]:
    """Footprints and roof heights of the building regions of ``cover``, largest first."""
    p = params or FootprintParams()
    regions, n = ndimage.label(cover.cells == BUILDING_CELL, structure=np.ones((3, 3)))
    if n == 0:
        return []
    grid = cover.top.grid
    cell_of = cover.point_cell
    region = regions.ravel()[cell_of]
    roof = (cover.classes == BUILDING) & (region > 0)
    # Only the returns near a roof can be the nearest to a footprint cell.
    near = ndimage.binary_dilation(regions > 0, structure=np.ones((3, 3)), iterations=3).ravel()[cell_of]
    returns = _Returns(
        plan_tree(xyz[near, :2]),
        np.where(roof, region, 0)[near],
        regions,
        np.bincount(cell_of[near], minlength=regions.size).reshape(regions.shape),
        np.bincount(cell_of[roof], minlength=regions.size).reshape(regions.shape),
    )
    # each region's roof returns, grouped once rather than found by a pass over all returns per region
    roofs = np.flatnonzero(roof)
    roofs = roofs[np.argsort(region[roofs], kind="stable")]
    starts = np.searchsorted(region[roofs], np.arange(1, n + 2))
    out = []
    for k, sl in enumerate(ndimage.find_objects(regions), start=1):
        mine = roofs[starts[k - 1] : starts[k]]
        if sl is None or len(mine) == 0:
            continue
        shape = _footprint(returns, k, grid, sl, p)
        if shape is None:
            continue
        height = float(np.quantile(cover.height[mine], ROOF_TOP))
        walls = fit_walls(shape, resolution=grid.cell) if p.walls else None
        out.append(Building(shape.simplify(p.simplify * grid.cell) if walls is None else walls, height))
    return sorted(out, key=lambda b: -b.area)


@dataclass(frozen=True)
class _Returns:
    """The returns near the roof regions: their k-d tree and each one's region (0: no roof
    return); the regions; and per texture cell, its count of returns and of roof returns."""

    tree: cKDTree
    label: NDArray[np.intp]
    regions: NDArray[np.int32]
    count: NDArray[np.intp]
    roof: NDArray[np.intp]

    def settled(self, k: int, rows: slice, cols: slice) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
        """In the box ``rows`` × ``cols`` of the texture grid (it may reach past the grid), the
        cells whose fine cells' nearest return is known without a search, and whether it is a
        roof return of region ``k`` there. Such a cell holds a return, so its fine cells' nearest
        lies within its diagonal, and any return outside the 5 × 5 cells around it lies farther:
        where those 25 cells' returns are all region ``k``'s roof returns, or none is, every fine
        cell of it has that answer, whichever return is nearest."""
        box = (slice(rows.start - 2, rows.stop + 2), slice(cols.start - 2, cols.stop + 2))
        count = _window(self.count, *box)
        own = np.where(_window(self.regions, *box) == k, _window(self.roof, *box), 0)
        total, theirs = _sum_5x5(count), _sum_5x5(own)
        held = count[2:-2, 2:-2] > 0
        return held & ((theirs == total) | (theirs == 0)), theirs > 0


def _window(a: NDArray[np.integer[Any]], rows: slice, cols: slice) -> NDArray[np.intp]:
    """``a[rows, cols]``, zero where the box reaches past ``a``."""
    out = np.zeros((rows.stop - rows.start, cols.stop - cols.start), np.intp)
    r0, c0 = max(rows.start, 0), max(cols.start, 0)
    r1, c1 = min(rows.stop, a.shape[0]), min(cols.stop, a.shape[1])
    if r1 > r0 and c1 > c0:
        out[r0 - rows.start : r1 - rows.start, c0 - cols.start : c1 - cols.start] = a[r0:r1, c0:c1]
    return out


def _sum_5x5(a: NDArray[np.intp]) -> NDArray[np.intp]:
    """Sums over the 5 × 5 cells around each cell of ``a`` but its two-cell border."""
    return np.asarray(ndimage.correlate(a, np.ones((5, 5), np.intp), mode="constant")[2:-2, 2:-2], np.intp)


def _footprint(returns: _Returns, k: int, grid: Grid, sl: tuple[slice, slice], p: FootprintParams) -> Any:
    """The footprint of region ``k`` (``sl``: its box on the texture grid)."""
    rows, cols = sl
    fine = grid.cell / p.refine
    x0 = grid.x0 + (cols.start - REACH) * grid.cell
    y0 = grid.y0 + (rows.start - REACH) * grid.cell
    region = np.pad(returns.regions[sl] == k, REACH)
    reach = ndimage.binary_dilation(region, np.ones((3, 3), bool), iterations=REACH)
    box = (slice(rows.start - REACH, rows.stop + REACH), slice(cols.start - REACH, cols.stop + REACH))
    settled, mine = returns.settled(k, *box)
    ones = np.ones((p.refine, p.refine), bool)
    mask = np.kron(reach & settled & mine, ones)
    fgrid = Grid(x0, y0, fine, mask.shape)
    xs, ys = fgrid.centres()
    r, c = np.nonzero(np.kron(reach & ~settled, ones))
    _, nearest = returns.tree.query(np.column_stack([xs[c], ys[r]]))
    mask[r, c] = returns.label[nearest] == k
    lab, m = ndimage.label(mask, structure=np.ones((3, 3)))
    if m == 0:
        return None
    largest = int(np.argmax(np.bincount(lab.ravel())[1:])) + 1
    return outlines(np.where(lab == largest, 0, -1), x0=fgrid.x0, y0=fgrid.y0, cell=fgrid.cell).get(0)
