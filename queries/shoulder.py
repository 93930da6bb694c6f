"""How high a linear form still stands a little off its crest: a wall drops at once, a ridge does not.

A wall and a ridge make the same chain of ridge tiles, and the same is true of a
narrow and a broad ditch. What differs is the cross-section: 0.8–1.6 m off a
wall's crest (walls are up to 1.6 m wide) the ground is back at the foot, while a
ridge 3–6 m wide still stands at half its height or more. The *shoulder* of a
line is that share: the median height, above the terrain beside the form, of the
stored tile corners ``near``–``far`` metres off the line on one side, over the
form's own height (depth for ``Measure.DEPTH``), the larger of the two sides.
The larger, because a centre line drawn along one edge of a flat top has the top
on one side only.

The tile corners are every stored node of a level's lattice one tile apart: they
are always kept, and a line at any bearing but the lattice's own meets them at all
offsets. A line along the lattice within 0.4 m of a row of corners has none in the
band: its shoulder is NaN, which the filters read as "cannot tell, a ridge". Reading
further out instead (to 2 m) would make a 4 m ridge look like a wall. The terrain
beside a corner is read ``side`` metres off the line on both sides and interpolated
linearly across the form.
"""

from __future__ import annotations

import numpy as np
import shapely
from numpy.typing import NDArray

from tdb.options import Measure
from tdb.tiles import SUBGRID, NodeLattice

STEP = 0.5  # m along the line either side of a foot point, for the line's direction there


def _corners(lattice: NodeLattice) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    step = SUBGRID - 1
    first_i, first_j = -lattice.i0 % step, -lattice.j0 % step
    z = lattice.z[first_j::step, first_i::step]
    jj, ii = np.nonzero(~np.isnan(z))
    x = ((lattice.i0 + first_i + ii * step) * lattice.spacing).astype(np.float64)
    y = ((lattice.j0 + first_j + jj * step) * lattice.spacing).astype(np.float64)
    return x, y, z[jj, ii]


def shoulders(
    lattice: NodeLattice,
    lines: list[shapely.Geometry],
    heights: NDArray[np.float64],
    *,
    measure: Measure = Measure.HEIGHT,
    near: float = 0.8,
    far: float = 1.6,
    side: float = 5.0,
) -> NDArray[np.float64]:
    """Shoulder (share of ``heights``, see the module) of each line; NaN where no corner
    lies in the band on either side, or the terrain beside is unknown.

    Parameters
    ----------
    lattice : the level's stored nodes.
    lines : centre lines (LineString or MultiLineString), one per form.
    heights : each form's height (or depth) in metres.
    measure : ``height`` (ridges, walls) or ``depth`` (ditches).
    near, far : the band of offsets (m) from the line whose corners are read.
    side : offset (m) at which the terrain beside the form is read.
    """
    out = np.full(len(lines), np.nan)
    cx, cy, cz = _corners(lattice)
    if len(cx) == 0:
        return out
    corners = shapely.points(cx, cy)
    tree = shapely.STRtree(corners)
    sign = measure.sign
    for k, (line, height) in enumerate(zip(lines, heights)):
        if line is None or line.is_empty or not np.isfinite(height) or height <= 0:
            continue
        pick = tree.query(line, predicate="dwithin", distance=far)
        dist = shapely.distance(corners[pick], line)
        pick, dist = pick[dist > near], dist[dist > near]
        if len(pick) == 0:
            continue
        # the line's direction at each corner's foot point, from two points STEP either side
        at = shapely.line_locate_point(line, corners[pick])
        a = shapely.line_interpolate_point(line, np.maximum(at - STEP, 0.0))
        b = shapely.line_interpolate_point(line, np.minimum(at + STEP, line.length))
        foot = shapely.line_interpolate_point(line, at)
        tx, ty = shapely.get_x(b) - shapely.get_x(a), shapely.get_y(b) - shapely.get_y(a)
        norm = np.hypot(tx, ty)
        with np.errstate(invalid="ignore", divide="ignore"):
            nx, ny = -ty / norm, tx / norm
        fx, fy = shapely.get_x(foot), shapely.get_y(foot)
        left = lattice.corners(fx + side * nx, fy + side * ny)
        right = lattice.corners(fx - side * nx, fy - side * ny)
        across = np.sign((cx[pick] - fx) * nx + (cy[pick] - fy) * ny)
        terrain = right + (left - right) * (across * dist + side) / (2 * side)
        share = sign * (cz[pick] - terrain) / height
        sides = [share[(across == s) & np.isfinite(share)] for s in (-1.0, 1.0)]
        out[k] = max((float(np.median(v)) for v in sides if len(v)), default=np.nan)
    return out
