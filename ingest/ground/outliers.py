"""Low outliers: points far below every plausible ground around them.

Multipath and bird-strike returns can lie tens of metres below the terrain; a
filter that grows ground from the lowest points would anchor on them.

The test compares the lowest point of each small cell with the lowest points
around it (the lower envelope), never with all its neighbours, since under trees
those are leaves. A k-d tree query for every envelope point would take most of
the test; the 3 × 3 block of cells picks the suspects first, leniently, and only
those are queried: a few percent of the cells on ordinary data.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import reduce

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import Delaunay, QhullError

from ingest.ground.grids import CellSort, Grid, heights_of, lowest_per_cell, occupied_area
from ingest.ground.morphology import progressive_opening
from tdb.fill import fill_nearest
from tdb.kdtree import plan_tree

DENSITY_BLOCK = 4.0  # m: the blocks a survey's occupied area is counted in


def point_density(xy: NDArray[np.float64]) -> float:
    """Points per m² over the occupied area (:data:`DENSITY_BLOCK` blocks that hold a point), so
    that gaps and an irregular outline do not thin it."""
    return len(xy) / occupied_area(xy, block=DENSITY_BLOCK)


@dataclass(frozen=True)
class OutlierTest:
    """A point of the lower envelope is an outlier where it lies more than ``drop`` m under the
    ``rank``-th lowest of its ``k`` nearest envelope points; ``passes``: times the envelope is
    taken again without the outliers found."""

    k: int = 12
    rank: int = 3
    drop: float = 3.0
    passes: int = 2


def low_outliers(
    xyz: NDArray[np.float64],
    *,
    density: float | None = None,
    envelope_points: float = 16.0,
    test: OutlierTest = OutlierTest(),
    by_height: NDArray[np.intp] | None = None,
) -> NDArray[np.bool_]:
    """Mask of points lower than the ``rank``-th lowest of the ``k`` nearest points of the lower
    envelope by more than ``drop`` m (:class:`OutlierTest`). ``by_height``: the points' stable
    order by height, where the caller has it (:func:`tdb.sort.by_group`).

    The lower envelope is the lowest point of each cell of a grid sized to hold about
    ``envelope_points`` points at ``density`` (points per m²; None measures it on ``xyz``; a
    survey modelled in blocks passes the whole survey's, so every block builds the grid the
    whole would). Only a cell's lowest point can be an outlier, and it is judged against the
    lowest points around it, not against all its neighbours: under a canopy a ground return's
    nearest points are leaves metres above it, and a test on all neighbours took 10–25 % of
    the ground under the forests of ``../shared/data/las`` for outliers.

    Taking the ``rank``-th lowest neighbour rather than the lowest lets small clusters of
    outliers (up to ``rank`` - 1 cells together) be found; a second pass, on the envelope
    without the first pass's outliers, catches what they hid (two outliers in one cell).
    """
    xyz = np.asarray(xyz, float)
    out = np.zeros(len(xyz), bool)
    k, rank, drop = test.k, test.rank, test.drop
    if len(xyz) <= k:
        return out
    density = density or point_density(xyz[:, :2])
    grid = Grid.covering(xyz[:, :2], float(np.sqrt(envelope_points / density)))
    cells = CellSort.of(grid, xyz, by_height=by_height)
    for _ in range(test.passes):
        lowest = cells.lowest(~out)
        envelope = lowest[lowest >= 0]
        if len(envelope) <= k:
            break
        z = heights_of(lowest, xyz)
        # Querying every envelope point took most of this test; the 3 x 3 block of cells picks
        # the suspects first, leniently.
        suspects = lowest[z < _block_floor(z, rank) - drop / 2]
        if len(suspects) == 0:
            break
        _, nb = plan_tree(xyz[envelope, :2]).query(xyz[suspects, :2], k=k + 1)
        # the nearest hit is the point itself
        floor = np.sort(xyz[envelope[nb[:, 1:]], 2], axis=1)[:, rank - 1]
        new = suspects[xyz[suspects, 2] < floor - drop]
        if len(new) == 0:
            break
        out[new] = True
    return out


def _block_floor(z: NDArray[np.float64], rank: int) -> NDArray[np.float64]:
    """Per cell, the ``rank``-th lowest of the eight cells around it (NaN cells are empty;
    +inf where fewer than ``rank`` of them hold a point)."""
    rows, cols = z.shape
    padded = np.pad(np.where(np.isnan(z), np.inf, z), 1, constant_values=np.inf)
    around = np.stack(
        [padded[i : i + rows, j : j + cols] for i in range(3) for j in range(3) if (i, j) != (1, 1)], axis=2
    )
    around.partition(rank - 1, axis=2)
    return around[:, :, rank - 1]


def deep_pits(
    xyz: NDArray[np.float64], *, cell: float = 1.0, window: float = 8.0, slope: float = 3.0, depth: float = 2.0
) -> NDArray[np.bool_]:
    """Mask of points in clusters of low outliers too big for :func:`low_outliers`.

    The opening of the upside-down lowest-point raster finds pits up to ``window`` m
    in radius whose walls are steeper than ``slope`` beyond ``depth`` m; a point in
    such a pit is an outlier if it lies more than ``depth`` below the nearest cell
    that is not a pit.
    """
    grid = Grid.covering(xyz[:, :2], cell)
    zmin = lowest_per_cell(grid, xyz)
    pits = progressive_opening(-zmin, cell=cell, max_window=window, slope=slope, offset=depth)
    if not pits.any():
        return np.zeros(len(xyz), bool)
    rim = fill_nearest(np.where(pits, np.nan, zmin))
    row, col = grid.index(xyz[:, :2])
    return pits[row, col] & (xyz[:, 2] < rim[row, col] - depth)


def ground_spikes(
    xyz: NDArray[np.float64],
    ground: NDArray[np.bool_],
    *,
    k: int = 8,
    base: float = 0.5,
    slope: float = 1.0,
    reach: float = 5.0,
    cells: CellSort | None = None,
) -> NDArray[np.bool_]:
    """Mask of ground points that lie more than ``base`` below every other ground point of their
    cell and the eight cells around, and below each of their ``k`` nearest ground neighbours
    (within ``reach`` m) by more than ``base`` + ``slope`` × the distance to it: one-point pits.

    :func:`low_outliers` needs a 3 m drop below its neighbours, all points counted, because a
    ground point among tree or roof returns lies well below them; a lower bar there cost the
    ISPRS samples' kappa. Among ground points alone, one point 1–3 m below all of its
    neighbours is no terrain, and it would make a pit 1–2 m across in the dense model.

    ``cells`` (default: 1 m cells) sorts the points by cell; the cell test picks the few
    candidates, and only the ground points within ``reach`` of them go into a k-d tree.
    """
    xyz = np.asarray(xyz, float)
    out = np.zeros(len(xyz), bool)
    if np.count_nonzero(ground) <= k:
        return out
    cells = cells or CellSort.of(Grid.covering(xyz[:, :2], 1.0), xyz)
    rows, cols = cells.grid.shape
    # the ground points by cell, then height
    on = ground[cells.order]
    order, cell = cells.order[on], cells.cell[on]
    z = xyz[order, 2]
    head = np.flatnonzero(np.r_[True, cell[1:] != cell[:-1]])
    low = np.full(rows * cols, np.inf)
    low[cell[head]] = z[head]
    nxt = np.minimum(head + 1, len(z) - 1)
    second = np.where((head + 1 < len(z)) & (cell[nxt] == cell[head]), z[nxt], np.inf)
    head = head[z[head] < second - base]
    # of those, the ones under the lowest ground of each of the eight cells around
    r, c = cell[head] // cols, cell[head] % cols
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            if not (dr or dc):
                continue
            rr, cc = r + dr, c + dc
            inside = (rr >= 0) & (rr < rows) & (cc >= 0) & (cc < cols)
            beside = np.where(inside, low[np.where(inside, rr * cols + cc, 0)], np.inf)
            keep = z[head] < beside - base
            head, r, c = head[keep], r[keep], c[keep]
    if len(head) == 0:
        return out
    cand = order[head]
    # the ground points within reach of a candidate: its cell's window of whole cells
    w = int(np.ceil(reach / cells.grid.cell))
    d = np.arange(-w, w + 1)
    near = np.zeros(rows * cols, bool)
    rr = np.clip(r[:, None, None] + d[None, :, None], 0, rows - 1)
    cc = np.clip(c[:, None, None] + d[None, None, :], 0, cols - 1)
    near[(rr * cols + cc).ravel()] = True
    local = np.sort(order[near[cell]])
    if len(local) <= k:
        return out
    dist, nb = plan_tree(xyz[local, :2]).query(xyz[cand, :2], k=k + 1)
    nb = local[nb]
    # the candidate itself is among them (at distance 0, maybe tied with a duplicate): skip it
    own = nb == cand[:, None]
    keep_nb = np.argsort(own, axis=1, kind="stable")[:, :k]
    nb, dist = np.take_along_axis(nb, keep_nb, axis=1), np.take_along_axis(dist, keep_nb, axis=1)
    spike = (xyz[nb, 2] - xyz[cand, 2][:, None] > base + slope * dist).all(axis=1)
    out[cand[spike]] = True
    return out


BLOCK = 2.0  # m: the raster that picks the suspects
# m: how far the ground a suspect lies under is looked for, block by block, so that the 45° rise
# allowed is that of the nearest ground, not of a coarser step beyond it
REACH = tuple(BLOCK * k for k in range(1, 8))


@dataclass(frozen=True)
class SunkenShape:
    """A sunken group: at most ``max_points`` ground points, more than ``depth`` m below all the
    terrain beside them; points join where their height step is at most ``step`` m + ``slope`` ×
    their distance (counted up to ``span`` m)."""

    depth: float = 10.0
    step: float = 1.0
    slope: float = 2.0
    span: float = 3.0
    max_points: int = 500


def sunken_groups(
    xyz: NDArray[np.float64],
    ground: NDArray[np.bool_],
    *,
    shape: SunkenShape = SunkenShape(),
    cells: CellSort | None = None,
) -> NDArray[np.bool_]:
    """Mask of ground points in small groups sunk more than ``shape.depth`` m below all the ground
    around (:class:`SunkenShape`).

    Multipath returns under water or glass can scatter tens of metres below a void in the
    ground, spread wider than :func:`deep_pits` opens and too uneven for
    :func:`ground_spikes`. Ground points are joined to their Delaunay neighbours where the
    height step is small (the shape's step and slope); joined sets of more than ``max_points``
    (and the largest one) are terrain. The other points, taken together where they touch, are
    one group; a group of at most ``max_points`` whose every terrain neighbour lies more than
    ``depth`` above it is no terrain.

    Only the ground near a 2 m block whose lowest ground lies more than ``depth`` below the
    lowest ground of a block up to 14 m away (beyond the rise of a 45° slope) is looked at: on
    ordinary terrain, none. ``cells`` (default: 1 m cells) sorts the points by cell.
    """
    xyz = np.asarray(xyz, float)
    out = np.zeros(len(xyz), bool)
    if np.count_nonzero(ground) < 4:
        return out
    depth = shape.depth
    cells = cells or CellSort.of(Grid.covering(xyz[:, :2], 1.0), xyz)
    low = heights_of(cells.lowest(ground), xyz)
    # blocks of about BLOCK m: the lowest and the highest of their cells' lowest ground
    f = max(1, round(BLOCK / cells.grid.cell))
    size = f * cells.grid.cell
    rows, cols = -(-low.shape[0] // f), -(-low.shape[1] // f)
    padded = np.full((rows * f, cols * f), np.nan)
    padded[: low.shape[0], : low.shape[1]] = low
    parts = [padded[i::f, j::f] for i in range(f) for j in range(f)]
    lo, hi = reduce(np.fmin, parts), reduce(np.fmax, parts)  # NaN only where a block is empty
    hi[np.isnan(hi)] = -np.inf
    steep = np.zeros((rows, cols), bool)
    for reach in REACH:
        w = max(1, round(reach / size))
        top = ndimage.maximum_filter(hi, size=2 * w + 1, mode="constant", cval=-np.inf)
        steep |= lo < top - depth - w * size
    if not steep.any():
        return out
    # the group around a suspect block, and the terrain beside it across a void
    near = ndimage.maximum_filter(steep, size=2 * round(REACH[-1] / size) + 1)
    gi = np.flatnonzero(ground)
    row, col = cells.grid.index(xyz[gi, :2])
    row, col = row // f, col // f
    inside = near[row, col]
    local = gi[inside]
    # where the area is cut from the rest of the ground, a group's terrain may lie outside it
    rim = near & ~ndimage.binary_erosion(near, structure=np.ones((3, 3)), border_value=1)
    cut = rim[row[inside], col[inside]]
    sunk = _sunken(xyz[local], cut, shape)
    out[local[sunk]] = True
    return out


def _sunken(xyz: NDArray[np.float64], cut: NDArray[np.bool_], shape: SunkenShape) -> NDArray[np.bool_]:
    """:func:`sunken_groups` on the ground points ``xyz`` of one area; a group holding a point
    ``cut`` marks (on the area's rim) is kept."""
    depth, step, slope, span, max_points = shape.depth, shape.step, shape.slope, shape.span, shape.max_points
    n = len(xyz)
    try:
        tri = Delaunay(xyz[:, :2])
    except QhullError:  # fewer than three points off one line: no area to judge
        return np.zeros(n, bool)
    s = tri.simplices.astype(np.int64)
    pairs = np.concatenate([s[:, [0, 1]], s[:, [1, 2]], s[:, [2, 0]]])
    key = np.unique(pairs.min(axis=1) * n + pairs.max(axis=1))  # each edge once
    a, b = key // n, key % n
    dz = xyz[b, 2] - xyz[a, 2]
    # a long edge across a void says little about the slope: it joins only a small step
    joined = np.abs(dz) <= step + slope * np.minimum(np.hypot(*(xyz[b, :2] - xyz[a, :2]).T), span)
    size, label = _components(n, a[joined], b[joined])
    terrain = (size > max_points) | (size == size.max())
    on = terrain[label]
    # the points off the terrain, grouped wherever they touch whatever the step
    inner = ~on[a] & ~on[b]
    gsize, group = _components(n, a[inner], b[inner])
    # rise from a group to the terrain over every edge between them, either way round
    cross = on[a] != on[b]
    low = np.where(on[a[cross]], b[cross], a[cross])
    high = np.where(on[a[cross]], a[cross], b[cross])
    rise = np.full(len(gsize), np.inf)
    np.minimum.at(rise, group[low], xyz[high, 2] - xyz[low, 2])
    open_ = np.zeros(len(gsize), bool)
    open_[group[cut & ~on]] = True
    sunk = np.isfinite(rise) & (rise > depth) & (gsize <= max_points) & ~open_
    return ~on & sunk[group]


def _components(n: int, a: NDArray[np.intp], b: NDArray[np.intp]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """(size per component, component per node) of the undirected graph on ``n`` nodes with edges a–b."""
    graph = coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    return np.bincount(label), label
