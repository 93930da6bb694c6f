"""The default ground filter: morphological seeds refined on a TIN.

1. Low outliers are removed (:mod:`ingest.ground.outliers`).
2. Seeds: the lowest point per cell, opened with growing square windows; a cell
   is an object where the opening removes more than the slope allows for that
   window (the progressive morphological idea of Zhang et al. and SMRF).
3. Refinement: the seed ground is triangulated and every point is judged by its
   height above that TIN against a threshold that grows with the local slope;
   the ground so found is triangulated again and the test repeated, which lets
   ground creep up breaks of slope that the square windows cut off.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from scipy.spatial import cKDTree

from ingest.ground.grids import Grid, fill_nearest, lowest_per_cell
from ingest.ground.outliers import low_outliers
from ingest.ground.tin import surface_height, triangulate


@dataclass(frozen=True)
class AutoParams:
    cell: float = 1.0  # seed grid (m)
    max_window: float = 16.0  # largest opening window radius (m)
    slope: float = 0.15  # terrain slope the opening tolerates (rise/run)
    threshold: float = 0.4  # height above the ground TIN still ground on flat land (m)
    slope_scale: float = 1.25  # extra threshold per unit of local TIN slope
    below: float = 1.0  # points this far below the TIN are not ground (m)
    refinements: int = 4
    pit_window: float = 8.0  # widest low-outlier cluster (m, radius)
    pit_slope: float = 3.0  # pit walls steeper than this, beyond pit_depth, are not terrain
    pit_depth: float = 2.0
    thin: bool = True


def progressive_opening(
    zmin: NDArray[np.float64], *, cell: float, max_window: float, slope: float, offset: float = 0.05
) -> NDArray[np.bool_]:
    """Object mask of a lowest-point raster by openings with growing windows.

    A cell is an object once an opening lowers it by more than
    ``offset + slope × window radius``.
    """
    surface = fill_nearest(zmin)
    objects = np.zeros(zmin.shape, bool)
    radius = 1
    while radius * cell <= max_window:
        size = 2 * radius + 1
        # "nearest": terrain continues past the data edge, so a terrace cut by the
        # edge is not mistaken for an object narrower than the window.
        opened = ndimage.maximum_filter(
            ndimage.minimum_filter(surface, size=size, mode="nearest"), size=size, mode="nearest"
        )
        objects |= surface - opened > slope * radius * cell + offset
        surface = opened
        radius = radius * 2 if radius >= 4 else radius + 1
    return objects & ~np.isnan(zmin)


def tin_heights(ground_xyz: NDArray[np.float64], xy: NDArray[np.float64]) -> NDArray[np.float64]:
    """Height of the TIN of ``ground_xyz`` at ``xy``; outside its hull, the nearest ground point's."""
    out, simplex = surface_height(triangulate(ground_xyz[:, :2]), ground_xyz[:, 2], xy)
    inside = simplex >= 0
    if (~inside).any():
        _, nearest = cKDTree(ground_xyz[:, :2]).query(xy[~inside])
        out[~inside] = ground_xyz[nearest, 2]
    return out


def surface_slope(grid: Grid, ground_xyz: NDArray[np.float64]) -> NDArray[np.float64]:
    """Slope (rise/run) raster of the ground TIN sampled at cell centres, lightly smoothed."""
    xs, ys = grid.centres()
    gx, gy = np.meshgrid(xs, ys)
    dem = tin_heights(ground_xyz, np.column_stack([gx.ravel(), gy.ravel()])).reshape(grid.shape)
    dem = ndimage.uniform_filter(dem, size=3, mode="nearest")
    dy, dx = np.gradient(dem, grid.cell)
    return np.hypot(dx, dy)


def auto_ground(xyz: NDArray[np.float64], *, params: AutoParams | None = None) -> NDArray[np.bool_]:
    """Ground mask by the default filter (one parameter set for all data).

    Parameters
    ----------
    xyz : (N, 3) coordinates in metres.
    params : thresholds; the defaults are the product's single parameter set.
    """
    p = params or AutoParams()
    xyz = np.asarray(xyz, float)
    ground = np.zeros(len(xyz), bool)
    keep = np.flatnonzero(~low_outliers(xyz))
    pts = xyz[keep]
    grid = Grid.covering(pts[:, :2], p.cell)
    zmin, idx = lowest_per_cell(grid, pts)
    objects = progressive_opening(zmin, cell=p.cell, max_window=p.max_window, slope=p.slope)
    # Clusters of low outliers too big for the neighbour test: deep narrow pits,
    # found by the same opening of the upside-down surface.
    pits = progressive_opening(-zmin, cell=p.cell, max_window=p.pit_window, slope=p.pit_slope, offset=p.pit_depth)
    seeds = idx[(idx >= 0) & ~objects & ~pits]
    current = pts[seeds]
    for _ in range(p.refinements + 1):
        h = pts[:, 2] - tin_heights(current, pts[:, :2])
        slope = grid.sample(surface_slope(grid, current), pts[:, :2])
        is_ground = (h <= p.threshold + p.slope_scale * slope) & (h >= -p.below)
        # The next surface rests on the lowest ground point per cell: noise and
        # low clutter among the accepted points would otherwise lift it.
        _, low = lowest_per_cell(grid, pts[is_ground])
        current = pts[is_ground][low[low >= 0]] if p.thin else pts[is_ground]
    ground[keep[is_ground]] = True
    return ground
