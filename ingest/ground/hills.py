"""Hills the ground filter would cut: object groups that rise smoothly out of the ground.

The opening windows and the slope-scaled threshold cut the top off a steep hill,
a spoil heap or a broad embankment whose sides rise faster than ground can creep
up them, above all in sparse data, where one pass climbs one point spacing. What
sets such a group apart from a building or a tree is how it meets the ground: a
roof or a crown stands over the ground beside it, a hill starts at it. A group
of object cells (cells holding no ground point) is terrain where nearly every
cell's lowest point lies below a cone rising from the nearest ground point,
``h <= rise + slope * d``, both on the group's rim and inside it, and the group is
broad enough not to be a car or a shrub. A steeper group (under a cone of slope 1.5)
is terrain too where a twentieth of its rim cells lie within 1 m of the ground beside
them: a slope or an embankment runs into the ground at its foot and its top, while a
roof stands over the ground all round, however near the ground is.

The cells are sized to the point density (about 1.5 point spacings), so that a
hill in sparse data is one group and not hundreds of single cells.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from ingest.ground.grids import CellSort, Grid, occupied_area


def point_spacing(xy: NDArray[np.float64], *, block: float = 5.0) -> float:
    """Mean point spacing (m) over the occupied part of the extent (blocks of ``block`` m)."""
    return float(np.sqrt(occupied_area(xy, block=block) / max(len(xy), 1)))


@dataclass(frozen=True)
class HillShape:
    """A hill: a group of object cells, of cells ``spacings`` point spacings wide, under a cone of
    ``rise`` m and ``slope`` (rise/run) over the nearest ground for ``min_share`` of its cells and
    of its rim cells, at least ``min_area`` m²; or, where at least ``foot_share`` of its rim lies
    at most ``foot`` m over the ground (it meets the ground at its foot), under a cone of
    ``steep_slope`` for ``steep_share``."""

    spacings: float = 1.5
    rise: float = 0.5
    slope: float = 1.0
    min_share: float = 0.95
    min_area: float = 100.0
    steep_slope: float = 1.5
    steep_share: float = 0.9
    foot: float = 1.0
    foot_share: float = 0.05


def smooth_hills(
    xyz: NDArray[np.float64],
    ground: NDArray[np.bool_],
    *,
    cell: float,
    shape: HillShape = HillShape(),
    by_height: NDArray[np.intp] | None = None,
) -> NDArray[np.bool_]:
    """Points that are the lowest of their cell in a group of object cells that is a hill.

    Parameters
    ----------
    xyz : (N, 3) points.
    ground : (N,) the ground found so far.
    cell : cell size (m) of the groups' grid.
    shape : what makes a group a hill (:class:`HillShape`; its ``spacings`` is the caller's, to
        size ``cell``).
    by_height : the points' stable order by height, where the caller has it
        (:func:`tdb.sort.by_group`).
    """
    grid = Grid.covering(xyz[:, :2], cell)
    cells = CellSort.of(grid, xyz, by_height=by_height)
    lowest, lowest_ground = cells.lowest(), cells.lowest(ground)
    has_ground = lowest_ground >= 0
    objects = (lowest >= 0) & ~has_ground
    out = np.zeros(len(xyz), bool)
    if not objects.any() or not has_ground.any():
        return out
    _, (ri, ci) = ndimage.distance_transform_edt(~has_ground, return_indices=True)
    near = lowest_ground[ri, ci]
    own = np.where(objects, lowest, near)
    d = np.hypot(xyz[own, 0] - xyz[near, 0], xyz[own, 1] - xyz[near, 1])
    h = xyz[own, 2] - xyz[near, 2]
    labels, n = ndimage.label(objects, structure=np.ones((3, 3)))
    rim = objects & ndimage.binary_dilation(has_ground, structure=np.ones((3, 3)))

    def per_group(mask: NDArray[np.bool_]) -> NDArray[np.float64]:
        return np.bincount(labels.ravel(), mask.ravel(), minlength=n + 1).astype(np.float64)

    count, rims = per_group(objects), per_group(rim)

    def under(cone: float, share: float) -> NDArray[np.bool_]:
        below = objects & (h <= shape.rise + cone * d)
        return (per_group(below) >= share * count) & (per_group(below & rim) >= share * rims)

    # A steeper group is still terrain where part of its rim runs into the ground (the foot or
    # the top of a slope); a roof stands over the ground all round, however near it is.
    meets = per_group(rim & (h <= shape.foot)) >= shape.foot_share * rims
    ok = under(shape.slope, shape.min_share) | (under(shape.steep_slope, shape.steep_share) & meets)
    ok &= count * cell * cell >= shape.min_area
    ok[0] = False
    out[lowest[ok[labels] & objects]] = True
    return out
