"""Roofs wider than the opening's largest window: raised ground enclosed by walls.

The openings take an object for an object only where a window fits over it: a roof wider than
the largest window (a hall, a warehouse, a station) keeps its middle as seed ground, and the
refinement passes spread that ground to its edges. What sets such a roof apart from terrain is
how it meets the ground around it: a wall drops from its edge to the ground in one cell,
all round, and the ground at the wall's foot goes on level. A plateau among terrain meets it
somewhere (a ramp, a slope), a steep hill falls away over many cells, and a terrace rises on
its uphill side.

The ground's lowest points are gridded (about 1.5 point spacings, as the hills stage does, so
that sparse data has few empty cells) and joined into surfaces wherever neighbouring cells
differ by less than a storey. A surface is a roof where it lies inside the grid (a surface cut
by the data's edge may go on beyond it), nearly all of its neighbouring ground lies a storey
or more below its edge, at a foot that does not go on falling, and more of its outline drops
than rises (a yard among buildings lies under them).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ingest.ground.grids import Grid, lowest_per_cell

# The eight neighbours of a cell (row, column offsets); the first four join surfaces.
NEIGHBOURS = ((0, 1), (1, 0), (1, 1), (1, -1), (0, -1), (-1, 0), (-1, -1), (-1, 1))


@dataclass(frozen=True)
class RoofShape:
    """A roof: a surface of ground cells whose neighbouring ground lies at least ``step`` m (a
    storey) below its edge for ``min_share`` of its neighbours, at a foot that falls less than
    half a step further."""

    step: float = 2.5
    min_share: float = 0.9


def raised_roofs(
    xyz: NDArray[np.float64],
    ground: NDArray[np.bool_],
    *,
    cell: float,
    shape: RoofShape = RoofShape(),
) -> NDArray[np.bool_]:
    """Ground points that lie on a roof (:class:`RoofShape`).

    Parameters
    ----------
    xyz : (N, 3) points.
    ground : (N,) the ground found so far.
    cell : cell size (m) of the surfaces' grid.
    shape : what makes a surface a roof.
    """
    grid = Grid.covering(xyz[:, :2], cell)
    z, lowest = lowest_per_cell(grid, xyz[ground]), lowest_per_cell(grid, xyz)
    empty = np.isnan(lowest)
    under = np.where(np.isnan(z), lowest, np.nan)  # the lowest point of a cell without ground
    # A gap in the data may hide the ground at a roof's foot, or terrain going on: it counts
    # against a roof. Random sampling leaves empty cells, but hardly ever 3 x 3 of them.
    void = ndimage.binary_opening(empty, structure=np.ones((3, 3), bool))
    roofs = np.zeros(grid.shape, bool)
    # A roof of several levels shows its highest level first; the lower ones once it is gone.
    while (found := _roof_cells(np.where(roofs, np.nan, z), under, void, shape)).any():
        roofs |= found
    # A cell astride a roof's wall holds the ground at its foot and the roof's edge over it.
    astride = ndimage.binary_dilation(roofs, structure=np.ones((3, 3), bool)) & ~roofs
    row, col = grid.index(xyz[:, :2])
    eaves = astride[row, col] & (xyz[:, 2] - z[row, col] > shape.step)
    return ground & (roofs[row, col] | eaves)


@dataclass(frozen=True)
class _Cells:
    """The rasters a surface's neighbours are read from."""

    z: NDArray[np.float64]  # the lowest ground point of each cell (NaN: none)
    under: NDArray[np.float64]  # the lowest point of each cell holding no ground (NaN: none)
    void: NDArray[np.bool_]  # the gaps in the data
    label: NDArray[np.intp]  # each cell's surface (-1: no ground)


def _roof_cells(
    z: NDArray[np.float64], under: NDArray[np.float64], void: NDArray[np.bool_], shape: RoofShape
) -> NDArray[np.bool_]:
    """Cells of the surfaces of ``z`` (NaN: no ground) that are roofs, where ``under`` is the
    lowest point of each cell holding no ground (NaN: none) and ``void`` marks the gaps in the
    data."""
    label, count = _surfaces(z, shape.step)
    cells = _Cells(z, under, void, label)
    judged, down, up = (np.zeros(count) for _ in range(3))
    # Only a surface's outline has neighbours of another kind, and a surface at the grid's edge
    # (the terrain, mostly) is never a roof: it may go on beyond the data.
    edge = np.unique(np.r_[label[0], label[-1], label[:, 0], label[:, -1]])
    outline = (ndimage.maximum_filter(label, size=3) != label) | (ndimage.minimum_filter(label, size=3) != label)
    r, c = np.nonzero(outline & (label >= 0) & ~np.isin(label, edge))
    own = label[r, c]
    for offset in NEIGHBOURS:
        seen, dropped, over = _beside(cells, r, c, offset, shape.step)
        judged += np.bincount(own[seen], minlength=count)
        down += np.bincount(own[dropped], minlength=count)
        up += np.bincount(own[over], minlength=count)
    # A roof drops to the ground beside it nearly everywhere the ground shows, and more of its
    # outline drops than rises: a yard among buildings, or a street between them, lies under
    # them. A higher part of the same building may rise over a lower roof on one side.
    roof = (judged > 0) & (down >= shape.min_share * judged) & (down > up)
    roof[edge[edge >= 0]] = False
    return (label >= 0) & roof[np.maximum(label, 0)]


def _beside(
    cells: _Cells, r: NDArray[np.intp], c: NDArray[np.intp], offset: tuple[int, int], step: float
) -> tuple[NDArray[np.bool_], NDArray[np.bool_], NDArray[np.bool_]]:
    """For surface cells (r, c) inside the grid's edge and their neighbours at ``offset``: whether
    the neighbour is ground or a gap (judged), whether it lies a wall's drop below, and whether it
    is an object standing a storey over the cell."""
    rows, cols = cells.z.shape
    r1, c1 = r + offset[0], c + offset[1]
    r2, c2 = np.clip(r1 + offset[0], 0, rows - 1), np.clip(c1 + offset[1], 0, cols - 1)
    zp, zq, zq2, zo = cells.z[r, c], cells.z[r1, c1], cells.z[r2, c2], cells.under[r1, c1]
    other = (cells.label[r1, c1] >= 0) & (cells.label[r1, c1] != cells.label[r, c])
    # A wall's foot is level ground; a steep slope goes on falling past it (NaN: nothing past).
    drop = other & (zp - zq > step) & ~(zq - zq2 > step / 2)
    # An object beside a surface whose lowest point lies a storey under it stands at a wall's foot.
    over, foot = zo - zp > step, zp - zo > step
    return other | cells.void[r1, c1] | foot, drop | foot, over


def _surfaces(z: NDArray[np.float64], step: float) -> tuple[NDArray[np.intp], int]:
    """Ground cells joined where neighbours differ by at most ``step``: a label per cell (-1: no
    ground) and how many surfaces."""
    rows, cols = z.shape
    index = np.arange(z.size).reshape(z.shape)
    heads, tails = [], []
    for dr, dc in NEIGHBOURS[:4]:
        a = (slice(0, rows - dr), slice(max(0, -dc), cols - max(0, dc)))
        b = (slice(dr, rows), slice(max(0, dc), cols + min(0, dc)))
        joined = np.abs(z[a] - z[b]) <= step  # NaN never joins
        heads.append(index[a][joined])
        tails.append(index[b][joined])
    head, tail = np.concatenate(heads), np.concatenate(tails)
    graph = coo_matrix((np.ones(len(head), np.int8), (head, tail)), shape=(z.size, z.size))
    _, comp = connected_components(graph, directed=False)
    has = np.isfinite(z).ravel()
    label = np.full(z.size, -1, np.intp)
    _, label[has] = np.unique(comp[has], return_inverse=True)
    return label.reshape(z.shape), int(label.max() + 1) if has.any() else 0
