"""How far a tile stands out of the terrain on both sides: the depth of a ditch, the height of a ridge.

A tile's category says it holds a valley or a ridge, but a ditch rim, the top of
an escarpment or the edge of an embankment hold the same shapes. What they lack is
relief on both sides: the lowest (highest) stored node of a ditch (ridge) tile lies
below (above) the terrain at ``reach`` metres on either side of it, in some
direction; a rim or a step has higher ground on one side and lower on the other.

The terrain beside a tile is read from the level's corner lattice (every tile
corner is stored), bilinearly; the extreme node from all of the tile's stored nodes.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tdb.options import Measure
from tdb.tiles import SUBGRID, NodeLattice, tile_key

_COS45 = float(np.sqrt(0.5))
PLANAR = 0.5  # terrain around a form is a plane where nothing strays from it by half the relief
RING_SHARE = 0.35  # ring_relief: a closed form's least relief over the ring, as a share of its most
_DIRS = np.array([[1.0, 0.0], [0.0, 1.0], [np.sqrt(0.5), np.sqrt(0.5)], [np.sqrt(0.5), -np.sqrt(0.5)]])


def extreme_nodes(
    lattice: NodeLattice,
    xg: NDArray[np.int64],
    yg: NDArray[np.int64],
    *,
    measure: Measure,
    detrend: int | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """x, y, z of each tile's lowest (``Measure.DEPTH``) or highest stored node (z NaN: none stored).

    With ``detrend`` (tiles), lowest and highest relative to the bilinear surface through
    the corners of the square reaching that many tiles beyond the tile (0: its own corners),
    so that on a slope the node picked is the one in the ditch, not the tile's downhill
    corner. For ``Measure.STEP`` the tile's centre, with z NaN.
    """
    s = lattice.spacing
    if measure is Measure.STEP:
        half = s * (SUBGRID - 1) / 2
        cx = np.asarray(xg, np.float64) + half
        cy = np.asarray(yg, np.float64) + half
        return cx, cy, np.full(len(cx), np.nan)
    di, dj = np.meshgrid(np.arange(SUBGRID), np.arange(SUBGRID))
    ni = np.rint(np.asarray(xg) / s).astype(np.int64)[:, None] + di.ravel()[None, :]
    nj = np.rint(np.asarray(yg) / s).astype(np.int64)[:, None] + dj.ravel()[None, :]
    z = lattice.tile_nodes(xg, yg).reshape(len(ni), SUBGRID * SUBGRID)
    rel = z if detrend is None else z - _corner_surface(lattice, xg, yg, di.ravel(), dj.ravel(), detrend)
    score = np.where(np.isnan(z), -np.inf, measure.sign * rel)
    k = score.argmax(axis=1)
    rows = np.arange(len(k))
    return ni[rows, k] * s, nj[rows, k] * s, z[rows, k]


def _corner_surface(
    lattice: NodeLattice,
    xg: NDArray[np.int64],
    yg: NDArray[np.int64],
    di: NDArray[np.int64],
    dj: NDArray[np.int64],
    margin: int,
) -> NDArray[np.float64]:
    """(T, nodes) bilinear surface through the corners of each tile's square widened by
    ``margin`` tiles each way, at the nodes offset (di, dj) from its corner; 0 where unknown."""
    step = SUBGRID - 1
    i0 = np.rint(np.asarray(xg) / lattice.spacing).astype(np.int64)[:, None] - margin * step
    j0 = np.rint(np.asarray(yg) / lattice.spacing).astype(np.int64)[:, None] - margin * step
    far = (2 * margin + 1) * step
    corner = [lattice.at(i0 + a * far, j0 + b * far) for a, b in ((0, 0), (1, 0), (0, 1), (1, 1))]
    u, v = (margin * step + di[None, :]) / far, (margin * step + dj[None, :]) / far
    plane = (1 - u) * (1 - v) * corner[0] + u * (1 - v) * corner[1] + (1 - u) * v * corner[2] + u * v * corner[3]
    return np.where(np.isnan(plane), 0.0, plane)


def two_sided_relief(
    lattice: NodeLattice,
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    z: NDArray[np.float64],
    *,
    measure: Measure,
    reach: float,
    along: NDArray[np.float64] | None = None,
) -> NDArray[np.float64]:
    """Depth (``Measure.DEPTH``) or height of points (x, y, z) below / above the terrain on both sides.

    For each of four directions the terrain is read at ``reach`` metres on either
    side of the point; the relief is the smaller of the two differences, and the
    point's relief the largest over the directions (NaN where z or the terrain
    beside it is unknown). ``Measure.STEP`` (an embankment's side) is the
    largest difference between the terrain on the two sides.

    On a slope across the line the smaller difference is the relief less the slope's rise
    over ``reach``. Where the terrain across is a plane, the relief is read against that
    plane (the chord between the two sides): the terrain read again ``reach`` farther out on
    each side keeps the chord's slope, straying from it by no more than :data:`PLANAR` of the
    relief. A step, a rim or a bank has level ground beyond it on both sides, so its sides
    are no plane, and it keeps the smaller difference.

    ``along`` (N, 2) gives each point's break line direction (NaN: none): directions
    closer than 45° to it are not read. Along its own line a ditch's rim or a wall's
    foot has the feature in the cells beside it and would seem to stand out.
    """
    sign = measure.sign
    best = np.full(len(x), -np.inf)
    for dx, dy in _DIRS:
        k = np.arange(len(x))
        if along is not None:  # NaN (no line) reads every direction
            with np.errstate(invalid="ignore"):
                k = k[~(np.abs(along @ np.array([dx, dy])) > _COS45 + 1e-9)]
        px, py = x[k], y[k]
        a = lattice.corners(px + reach * dx, py + reach * dy)
        b = lattice.corners(px - reach * dx, py - reach * dy)
        if measure is Measure.STEP:
            with np.errstate(invalid="ignore"):
                rel = np.abs(a - b)
        else:
            rel = _against_sides(lattice, px, py, z[k], a, b, (dx * reach, dy * reach), sign=sign)
        best[k] = np.fmax(best[k], rel)
    best[~np.isfinite(best)] = np.nan
    return best


def _against_sides(  # noqa: PLR0913 (the point, its two sides and the step to them)
    lattice: NodeLattice,
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    z: NDArray[np.float64],
    a: NDArray[np.float64],
    b: NDArray[np.float64],
    step: tuple[float, float],
    *,
    sign: float,
) -> NDArray[np.float64]:
    """Relief of z against the terrain ``a`` one ``step`` ahead and ``b`` one behind: against
    their chord where the terrain a step farther out on both sides keeps its slope, else the
    smaller of the two differences (:func:`two_sided_relief`)."""
    dx, dy = step
    ahead = lattice.corners(x + 2 * dx, y + 2 * dy)
    behind = lattice.corners(x - 2 * dx, y - 2 * dy)
    with np.errstate(invalid="ignore"):
        chord = sign * (z - (a + b) / 2)
        rise = (a - b) / 2  # the chord's rise over one step
        plane = (np.abs(ahead - a - rise) <= PLANAR * chord) & (np.abs(b - behind - rise) <= PLANAR * chord)
        return np.where(plane, chord, np.minimum(sign * (z - a), sign * (z - b)))


def ring_relief(
    lattice: NodeLattice,
    xg: NDArray[np.int64],
    yg: NDArray[np.int64],
    z: NDArray[np.float64],
    *,
    measure: Measure,
    tiles: int,
) -> NDArray[np.float64]:
    """How far heights ``z`` of tiles (xg, yg) stand above (below, ``Measure.DEPTH``) the highest
    (lowest) stored node of every tile in the ring ``tiles`` tiles away (NaN where any is unknown).

    A closed form stands out of all of it. A ridge or a ditch does not: the ring crosses its
    line, and the tiles there keep its crest or bottom among their nodes, where the corners
    alone would miss a narrow one. Nodes 0.5 m apart can still miss a narrow crest by a third
    of its height, so a tile counts (else 0) only where it stands out of every ring tile by
    :data:`RING_SHARE` of what it stands out of the lowest: a dome's top does, with its flanks
    well below it, and a line's crest does not.

    On a slope the ring's uphill side can stand over a mound's top. Where the ring is a plane
    (once that plane is taken off, no ring tile strays from the median by more than
    :data:`PLANAR` of the relief left), the relief is read against that plane; elsewhere, as it
    is. A line that ends near the tile, or a wide form's own flanks, bend the ring out of a
    plane, and a plane fitted through a line's end would make the end stand out.
    """
    sign = measure.sign
    ring = np.array([(di, dj) for di in range(-tiles, tiles + 1) for dj in range(-tiles, tiles + 1)])
    ring = ring[np.abs(ring).max(axis=1) == tiles]
    extreme = ring_extremes(lattice, np.asarray(xg), np.asarray(yg), ring, sign=sign)
    # The terrain's own slope across the ring, robustly: along each axis, the median over the
    # ring's opposite sides of the difference between facing tiles. A line through the tile
    # crosses both sides alike; one that ends near it, or a neighbour, moves few of the pairs.
    with np.errstate(invalid="ignore"):
        grads = []
        for axis in (0, 1):
            far = ring[:, axis] == tiles
            other = ring[:, 1 - axis]
            near = np.array([np.flatnonzero((ring[:, axis] == -tiles) & (other == o))[0] for o in other[far]])
            grads.append(np.median(extreme[:, far] - extreme[:, near], axis=1) / (2 * tiles))
        level = extreme - grads[0][:, None] * ring[:, 0] - grads[1][:, None] * ring[:, 1]
        z = np.asarray(z, np.float64)[:, None]
        raw, flat = _least_relief(sign * (z - extreme)), _least_relief(sign * (z - level))
        known = ~np.isnan(level).any(axis=1)  # elsewhere both reliefs are NaN already
        spread = np.full(len(level), np.inf)
        spread[known] = np.abs(level[known] - np.median(level[known], axis=1)[:, None]).max(axis=1)
        out = np.where(spread <= PLANAR * flat, flat, raw)
    return out


def _least_relief(rel: NDArray[np.float64]) -> NDArray[np.float64]:
    """Least of each row of reliefs against the ring tiles; 0 under :data:`RING_SHARE` of the most."""
    out = np.where(np.isnan(rel).any(axis=1), np.nan, rel.min(axis=1))  # unknown terrain: NaN
    return np.where(~(out < RING_SHARE * rel.max(axis=1)), out, 0.0)


def ring_extremes(
    lattice: NodeLattice,
    xg: NDArray[np.int64],
    yg: NDArray[np.int64],
    ring: NDArray[np.int64],
    *,
    sign: float,
    whole: bool | None = None,
) -> NDArray[np.float64]:
    """(T, len(ring)) highest (``sign`` −1: lowest) stored node of the tiles at offsets ``ring``
    (in tiles) from tiles (xg, yg); NaN where a tile has none.

    With ``whole`` the extremes of every tile of the lattice are taken first (one pass over it:
    a query over a whole area), otherwise those of the ring tiles alone (a few regions in a large
    lattice, as change typing has). By default, whichever reads fewer nodes.
    """
    step = SUBGRID - 1
    size = round(lattice.spacing * step)
    rows, cols = lattice.z.shape
    if whole is None:
        whole = len(xg) * len(ring) > (rows // step + 1) * (cols // step + 1)
    if not whole:
        rx = (xg[:, None] + ring[:, 0] * size).ravel()
        ry = (yg[:, None] + ring[:, 1] * size).ravel()
        _, first, inverse = np.unique(tile_key(rx // size, ry // size), return_index=True, return_inverse=True)
        nodes = lattice.tile_nodes(rx[first], ry[first]).reshape(len(first), -1)
        return nan_extreme(nodes, sign, axis=1)[inverse].reshape(len(xg), len(ring))
    extremes, i0, j0 = _tile_extremes(lattice, sign)
    ti = np.rint(xg / lattice.spacing).astype(np.int64)[:, None] // step - i0 + ring[:, 0]
    tj = np.rint(yg / lattice.spacing).astype(np.int64)[:, None] // step - j0 + ring[:, 1]
    r, c = extremes.shape
    inside = (ti >= 0) & (tj >= 0) & (ti < c) & (tj < r)
    return np.where(inside, extremes[np.where(inside, tj, 0), np.where(inside, ti, 0)], np.nan)


def _tile_extremes(lattice: NodeLattice, sign: float) -> tuple[NDArray[np.float64], int, int]:
    """Highest (``sign`` −1: lowest) stored node of every tile the lattice touches, NaN where none,
    and the tile index of the grid's first row and column."""
    step = SUBGRID - 1
    if lattice.z.size == 0:
        return np.full((0, 0), np.nan), 0, 0
    # Pad with no-data so that the grid starts and ends on tile corners, one tile wider each way:
    # a tile whose edge nodes alone lie on the lattice has those as its extremes.
    left, below = lattice.i0 % step + step, lattice.j0 % step + step
    rows, cols = lattice.z.shape
    right = (-(left + cols - 1)) % step + step
    above = (-(below + rows - 1)) % step + step
    z = np.pad(lattice.z, ((below, above), (left, right)), constant_values=np.nan)
    win = np.lib.stride_tricks.sliding_window_view(z, (SUBGRID, SUBGRID))[::step, ::step]
    return nan_extreme(win, sign, axis=(2, 3)), (lattice.i0 - left) // step, (lattice.j0 - below) // step


def nan_extreme(values: NDArray[np.float64], sign: float, *, axis: int | tuple[int, ...]) -> NDArray[np.float64]:
    """Largest (``sign`` −1: smallest) of ``values`` along ``axis``, NaN ignored; NaN where all are."""
    return np.asarray((np.fmax if sign > 0 else np.fmin).reduce(values, axis=axis), np.float64)


def tile_relief(
    lattice: NodeLattice,
    xg: NDArray[np.int64],
    yg: NDArray[np.int64],
    *,
    measure: Measure,
    reach: float,
    along: NDArray[np.float64] | None = None,
    around: bool = False,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Each tile's extreme node (x, y) and its two-sided relief.

    Three nodes compete: the plain extreme, the extreme against the tile's corner
    surface, and the extreme against the corner surface ``reach`` metres (in whole tiles)
    beyond the tile. The first misses a ditch crossing a sloping tile, the second one running through or
    near the tile's corners (the corner surface then dips into it); the tile keeps whichever
    stands out more, and the third only where neither stands out at all. With
    ``around`` (a closed form: mound, pit) the plain extreme against the ring of tiles
    ``reach`` metres away (:func:`ring_relief`).
    """
    wide = max(1, round(reach / (lattice.spacing * (SUBGRID - 1))))  # the reach in tiles
    if around:
        x, y, z = extreme_nodes(lattice, xg, yg, measure=measure)
        return x, y, ring_relief(lattice, xg, yg, z, measure=measure, tiles=wide)
    best: tuple[NDArray[np.float64], ...] | None = None
    for detrend in (None,) if measure is Measure.STEP else (None, 0, wide):
        x, y, z = extreme_nodes(lattice, xg, yg, measure=measure, detrend=detrend)
        rel = two_sided_relief(lattice, x, y, z, measure=measure, reach=reach, along=along)
        if best is None:
            best = (x, y, rel)
            continue
        better = np.nan_to_num(rel, nan=-np.inf) > np.nan_to_num(best[2], nan=-np.inf)
        if detrend == wide:
            # only where the tile's own nodes found nothing standing out: the wider surface
            # picked other nodes along the lines found, and those judged worse as lines
            better &= ~(best[2] > 0)
        best = tuple(np.where(better, new, old) for new, old in zip((x, y, rel), best))
    assert best is not None
    return best[0], best[1], best[2]
