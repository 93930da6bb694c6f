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
    tree = plan_tree(xyz[near, :2])
    label = np.where(roof, region, 0)[near]
    # each region's roof returns, grouped once rather than found by a pass over all returns per region
    roofs = np.flatnonzero(roof)
    roofs = roofs[np.argsort(region[roofs], kind="stable")]
    starts = np.searchsorted(region[roofs], np.arange(1, n + 2))
    out = []
    for k, sl in enumerate(ndimage.find_objects(regions), start=1):
        mine = roofs[starts[k - 1] : starts[k]]
        if sl is None or len(mine) == 0:
            continue
        shape = _footprint(tree, label, k, grid, regions[sl] == k, sl, p)
        if shape is None:
            continue
        height = float(np.quantile(cover.height[mine], ROOF_TOP))
        walls = fit_walls(shape, resolution=grid.cell) if p.walls else None
        out.append(Building(shape.simplify(p.simplify * grid.cell) if walls is None else walls, height))
    return sorted(out, key=lambda b: -b.area)


def _footprint(
    tree: cKDTree,
    label: NDArray[np.intp],
    k: int,
    grid: Grid,
    region: NDArray[np.bool_],
    sl: tuple[slice, slice],
    p: FootprintParams,
) -> Any:
    """The footprint of region ``k`` (``region``: its cells in the box ``sl`` of the texture grid)."""
    rows, cols = sl
    fine = grid.cell / p.refine
    x0 = grid.x0 + (cols.start - REACH) * grid.cell
    y0 = grid.y0 + (rows.start - REACH) * grid.cell
    reach = ndimage.binary_dilation(np.pad(region, REACH), np.ones((3, 3), bool), iterations=REACH)
    near = np.kron(reach, np.ones((p.refine, p.refine), bool))
    fgrid = Grid(x0, y0, fine, near.shape)
    xs, ys = fgrid.centres()
    r, c = np.nonzero(near)
    _, nearest = tree.query(np.column_stack([xs[c], ys[r]]))
    mask = np.zeros(near.shape, bool)
    mask[r, c] = label[nearest] == k
    lab, m = ndimage.label(mask, structure=np.ones((3, 3)))
    if m == 0:
        return None
    largest = int(np.argmax(np.bincount(lab.ravel())[1:])) + 1
    return outlines(np.where(lab == largest, 0, -1), x0=fgrid.x0, y0=fgrid.y0, cell=fgrid.cell).get(0)
