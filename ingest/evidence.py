"""Ground evidence of a survey's 2 m tiles (:mod:`tdb.evidence`), from its ground returns."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from scipy.spatial import cKDTree

from tdb.evidence import LEVEL, OVER, OVER_CAP, SUPPORT_SPACINGS, TileEvidence
from tdb.kdtree import plan_tree
from tdb.median import median_filter
from tdb.raster import Raster
from tdb.sort import by_group, highest_per_group, scatter_max, scatter_min

NEIGHBOURS = 16  # ground returns per neighbourhood: ten more than the quadratic's six terms
TOLERANCE = 0.1  # m per m: what a neighbour carried along the surface may fall short by
CHUNK = 20_000  # points per batch of plane fits: their neighbourhoods (15 MB) stay in the heap and the caches
DEEP_SHARE = 0.2  # a tile's depth is what this share of its ground returns reach, not one return
LAYER_TILES = 5  # the least window of a tile's layer: a narrow wall's two lifted edges are a minority


def envelope_lift(
    xyz: NDArray[np.float64],
    *,
    at: NDArray[np.intp] | None = None,
    k: int = NEIGHBOURS,
    tree: cKDTree | None = None,
) -> NDArray[np.float64]:
    """Per point (of ``at``, default all), how far (m) it stands above the lowest of its ``k``
    nearest neighbours in plan,
    each carried to it along the local surface (a quadratic fitted to the neighbourhood) and
    allowed :data:`TOLERANCE` per metre besides.

    Ground taken for ground lies on the lower envelope of its neighbourhood, on a slope or a bank
    alike (the quadratic carries its shape); low vegetation taken for the ground, among the ground
    seen through it, stands above it by about its height. Zero at the envelope (a point is one of
    its own neighbours). ``tree``: :func:`tdb.kdtree.plan_tree` of ``xyz``, where the caller has
    one."""
    xyz = np.asarray(xyz, float)
    at = np.arange(len(xyz)) if at is None else np.asarray(at, np.intp)
    if len(xyz) < k:
        return np.zeros(len(at))
    tree = tree if tree is not None else plan_tree(xyz[:, :2])
    out = np.empty(len(at))
    for s in range(0, len(at), CHUNK):
        p = xyz[at[s : s + CHUNK]]
        _, nb = tree.query(p[:, :2], k=k)
        q = xyz[nb] - p[:, None, :]  # neighbours about the point itself
        u, v = q[..., 0], q[..., 1]
        design = np.stack([np.ones_like(u), u, v, u * u, u * v, v * v], axis=-1)
        across = design.transpose(0, 2, 1)
        coef = np.linalg.solve(across @ design + 1e-6 * np.eye(6), across @ q[..., 2:3])[..., 0]
        # the surface's rise from each neighbour to the point: f(0) − f(u, v)
        rise = coef[:, None, 0] - (design @ coef[..., None])[..., 0]
        carried = q[..., 2] + rise + TOLERANCE * np.hypot(u, v)
        out[s : s + CHUNK] = np.maximum(-carried.min(axis=1), 0.0)
    return out


def tile_evidence(
    ground_xyz: NDArray[np.float64],
    xg: NDArray[np.int64],
    yg: NDArray[np.int64],
    *,
    spacing: float,
    surface: Raster,
    noise: float = 0.0,
    tree: cKDTree | None = None,
) -> TileEvidence:
    """Evidence of the 2 m tiles ``xg``, ``yg`` from the ground returns ``ground_xyz``, for a
    survey whose pulses lie ``spacing`` m apart with ground ``noise`` (σ, m) and the dense model
    ``surface`` made from them.

    A tile's lift is how far its highest ground return stands above its neighbourhood's lower
    envelope (:func:`envelope_lift`); a tile without any takes its neighbours' (3 × 3 tiles),
    the gap saying the rest. Its depth is how far the surface stands above its ground returns
    (:func:`tile_depth`), its layer the lift of the tiles around it (:func:`tile_layer`).
    ``tree``: :func:`tdb.kdtree.plan_tree` of ``ground_xyz``, where the caller has one.
    The returns not taken for ground over each tile and its pulses are NaN here: :func:`tile_over`
    and :func:`tile_pulses` measure them.
    """
    xg, yg = np.asarray(xg, np.int64), np.asarray(yg, np.int64)
    if len(xg) == 0:
        return TileEvidence.empty()
    g = np.asarray(ground_xyz, float)
    if tree is None and len(g):
        tree = plan_tree(g[:, :2])
    lift = _tile_lift(g, xg, yg, tree=tree)
    depth = tile_depth(g, surface, xg, yg)
    layer = tile_layer(lift, xg, yg, floor=noise_lift(spacing, noise), window=layer_window(spacing))
    radius = SUPPORT_SPACINGS * spacing
    reach = _node_reach(g, xg, yg, radius, tree=tree)
    beyond = np.maximum(reach - radius, 0.0)
    support = (beyond == 0).mean(axis=1)
    gap = beyond.mean(axis=1)
    none = np.full(len(xg), np.nan)
    fields = (lift, gap, depth, layer, none, none, none, none, np.sqrt(np.mean(reach**2, axis=1)), support)
    return TileEvidence(xg, yg, *(a.astype(np.float32) for a in fields))


def tile_over(
    others: NDArray[np.float64], surface: Raster, xg: NDArray[np.int64], yg: NDArray[np.int64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Per 2 m tile (corners ``xg``, ``yg``), the lowest and the highest height (m) over
    ``surface`` of the returns ``others`` (not taken for ground) that stand from :data:`OVER` to
    :data:`OVER_CAP` over it; NaN where none.

    What one survey took for ground and another did not (a low wall, a thicket's top) the other
    saw where the first's surface is: its returns there are the evidence that the two surveys
    differ in what they took for ground, not in the ground."""
    xg, yg = np.asarray(xg, np.int64), np.asarray(yg, np.int64)
    low, high = np.full(len(xg), np.nan), np.full(len(xg), np.nan)
    o = np.asarray(others, float)
    if len(o) == 0 or len(xg) == 0:
        return low, high
    grid = _TileGrid.of(xg, yg)
    h = o[:, 2] - surface.sample(o[:, 0], o[:, 1])
    cell = grid.cells(o[:, 0], o[:, 1])
    keep = (cell >= 0) & (h >= OVER) & (h <= OVER_CAP)  # NaN (off the surface) fails both
    lo, hi = np.full(grid.size, np.inf), np.full(grid.size, -np.inf)
    scatter_min(lo, cell[keep], h[keep])
    scatter_max(hi, cell[keep], h[keep])
    at = grid.cells_of_tiles(xg, yg)
    held = np.isfinite(lo[at])
    low[held], high[held] = lo[at][held], hi[at][held]
    return low, high


def tile_pulses(
    xy: NDArray[np.float64], ground: NDArray[np.bool_], xg: NDArray[np.int64], yg: NDArray[np.int64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Per 2 m tile (corners ``xg``, ``yg``), the pulses ``xy`` (their last returns) per m², and
    the share of them that ``ground`` marks as taken for ground (NaN where the tile holds none)."""
    xg, yg = np.asarray(xg, np.int64), np.asarray(yg, np.int64)
    density, share = np.zeros(len(xg)), np.full(len(xg), np.nan)
    if len(xy) == 0 or len(xg) == 0:
        return density, share
    grid = _TileGrid.of(xg, yg)
    cell = grid.cells(xy[:, 0], xy[:, 1])
    on = cell >= 0
    at = grid.cells_of_tiles(xg, yg)
    pulses = np.bincount(cell[on], minlength=grid.size)[at]
    grounded = np.bincount(cell[on], weights=np.asarray(ground, bool)[on], minlength=grid.size)[at]
    held = pulses > 0
    density[:] = pulses / LEVEL**2
    share[held] = grounded[held] / pulses[held]
    return density, share


def layer_window(spacing: float) -> int:
    """Tiles across the window whose median lift is a tile's layer, for pulses ``spacing`` m apart.

    A step lifts the returns whose neighbourhoods reach across it: a band as wide as a
    neighbourhood (:data:`NEIGHBOURS` returns, 2 √(k / π) spacings across) on either side of its
    edge. The window is twice the band in tiles, and one, so that such a band is a minority of
    every window; at least :data:`LAYER_TILES`, in which the two edges of a wall one tile wide are."""
    band = 2 * np.sqrt(NEIGHBOURS / np.pi) * spacing
    return max(LAYER_TILES, 2 * int(np.ceil(band / LEVEL)) + 1)


def tile_layer(
    lift: NDArray[np.float64],
    xg: NDArray[np.int64],
    yg: NDArray[np.int64],
    *,
    floor: float = 0.0,
    window: int = LAYER_TILES,
) -> NDArray[np.float64]:
    """Per 2 m tile (corners ``xg``, ``yg``), the median ``lift`` of the ``window`` × ``window``
    tiles around it (:func:`layer_window`; a tile not given counts as 0), less the ``floor`` that
    noise alone makes (:func:`noise_lift`), never below 0.

    Where a filter took a layer of vegetation for the ground (the understorey under a closed
    canopy, through which a few returns reach the ground), every tile's highest ground return
    stands over the ground seen near it by about the layer's height, so the median over an area
    keeps it. A step, a bank or a wall lifts the tiles along its edges alone (a quadratic does not
    follow a step): a band too narrow to be the median of the window."""
    xg, yg = np.asarray(xg, np.int64), np.asarray(yg, np.int64)
    if len(xg) == 0:
        return np.zeros(0)
    grid = _TileGrid.of(xg, yg)
    raster = np.zeros(grid.size, np.float32)
    at = grid.cells_of_tiles(xg, yg)
    raster[at] = np.nan_to_num(lift, nan=0.0)
    median = median_filter(raster.reshape(grid.shape), window, mode="constant")
    return np.maximum(median.ravel()[at].astype(float) - floor, 0.0)


NULL_SIDE = 40.0  # m: the side of the bare plane whose tiles' lift :func:`noise_lift` takes


def noise_lift(spacing: float, noise: float) -> float:
    """The median lift (m) of the 2 m tiles of bare, flat ground surveyed with pulses ``spacing`` m
    apart and ground ``noise`` σ (m): what the noise alone makes of a tile's highest return over
    its neighbours, whatever the ground. Measured on a plane sampled with a fixed seed, so that
    the same survey always gets the same figure."""
    if noise <= 0 or spacing <= 0:
        return 0.0
    rng = np.random.default_rng(0)
    n = round(NULL_SIDE * NULL_SIDE / spacing**2)
    x, y = rng.uniform(0, NULL_SIDE, n), rng.uniform(0, NULL_SIDE, n)
    # the tiles a few metres in, whose neighbourhoods lie wholly on the plane
    xg, yg = (a.ravel().astype(np.int64) for a in np.meshgrid(*[np.arange(8, NULL_SIDE - 8, LEVEL)] * 2))
    return float(np.median(_tile_lift(np.column_stack([x, y, rng.normal(0.0, noise, n)]), xg, yg)))


def tile_depth(
    ground_xyz: NDArray[np.float64], surface: Raster, xg: NDArray[np.int64], yg: NDArray[np.int64]
) -> NDArray[np.float64]:
    """Per 2 m tile (corners ``xg``, ``yg``), how far (m) ``surface`` stands above the ground
    returns ``ground_xyz`` in it, each compared with the surface where it lies: the depth that
    :data:`DEEP_SHARE` of them reach (the deepest where they are few); 0 where the tile holds
    none or none lies under the surface.

    A surface through ground returns and through low vegetation's top taken for ground runs
    between the two levels: the returns seen through the vegetation lie under it by about the
    vegetation's height, where on open ground they lie on it (within the post spacing's
    interpolation). At a wall's or a bank's foot the posts' interpolation also lifts the
    surface over the few returns nearest the step: one return does not make a tile's depth."""
    xg, yg = np.asarray(xg, np.int64), np.asarray(yg, np.int64)
    g = np.asarray(ground_xyz, float)
    if len(g) == 0 or len(xg) == 0:
        return np.zeros(len(xg))
    grid = _TileGrid.of(xg, yg)
    below = surface.sample(g[:, 0], g[:, 1]) - g[:, 2]
    cell = grid.cells(g[:, 0], g[:, 1])
    keep = np.flatnonzero(np.isfinite(below) & (cell >= 0))
    order, starts = _ranked(cell[keep], -below[keep])  # per tile, deepest first
    count = np.diff(np.r_[starts, len(order)])
    pick = keep[order[starts + np.floor((count - 1) * DEEP_SHARE).astype(np.intp)]]
    depth = np.zeros(grid.size)
    depth[cell[pick]] = np.maximum(below[pick], 0.0)
    return depth[grid.cells_of_tiles(xg, yg)]


@dataclass(frozen=True)
class _TileGrid:
    """The 2 m tiles' extent as a raster (south row first): a flat cell index per point or tile."""

    i0: int
    j0: int
    shape: tuple[int, int]

    @classmethod
    def of(cls, xg: NDArray[np.int64], yg: NDArray[np.int64]) -> _TileGrid:
        i0, j0 = int(xg.min() // LEVEL), int(yg.min() // LEVEL)
        return cls(i0, j0, (int(yg.max() // LEVEL) - j0 + 1, int(xg.max() // LEVEL) - i0 + 1))

    @property
    def size(self) -> int:
        return self.shape[0] * self.shape[1]

    def cells(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.int64]:
        """The cell of each point (−1 outside the grid)."""
        i = np.floor(x / LEVEL).astype(np.int64) - self.i0
        j = np.floor(y / LEVEL).astype(np.int64) - self.j0
        inside = (i >= 0) & (j >= 0) & (i < self.shape[1]) & (j < self.shape[0])
        return np.where(inside, j * self.shape[1] + i, -1)

    def cells_of_tiles(self, xg: NDArray[np.int64], yg: NDArray[np.int64]) -> NDArray[np.int64]:
        return (yg // LEVEL - self.j0) * self.shape[1] + (xg // LEVEL - self.i0)


def _ranked(cell: NDArray[np.int64], key: NDArray[np.float64]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """The order of the points by cell and, within one, by ``key``; and where each cell's run starts."""
    order = by_group(cell, key)
    run = cell[order]
    return order, np.flatnonzero(np.r_[True, run[1:] != run[:-1]]) if len(run) else order


def _tile_lift(
    g: NDArray[np.float64], xg: NDArray[np.int64], yg: NDArray[np.int64], *, tree: cKDTree | None = None
) -> NDArray[np.float64]:
    """Envelope lift (m) of each tile's highest ground return, or the mean of its neighbours'
    (3 × 3 tiles) where it has none, or 0. The highest return is the one vegetation lifts most;
    one per tile bounds the cost whatever the density."""
    grid = _TileGrid.of(xg, yg)
    total, count = np.zeros(grid.size), np.zeros(grid.size)
    if len(g):
        cell = grid.cells(g[:, 0], g[:, 1])
        inside = np.flatnonzero(cell >= 0)
        top = inside[highest_per_group(cell[inside], g[inside, 2])]
        total[cell[top]] = envelope_lift(g, at=top, tree=tree)
        count[cell[top]] = 1.0
    total, count = total.reshape(grid.shape), count.reshape(grid.shape)
    at = np.unravel_index(grid.cells_of_tiles(xg, yg), grid.shape)
    own = count[at]
    near_total = ndimage.uniform_filter(total, size=3, mode="constant")[at]
    near_count = ndimage.uniform_filter(count, size=3, mode="constant")[at]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(own > 0, total[at] / own, np.where(near_count > 0, near_total / near_count, 0.0))


def _node_reach(
    g: NDArray[np.float64],
    xg: NDArray[np.int64],
    yg: NDArray[np.int64],
    radius: float,
    *,
    tree: cKDTree | None,
) -> NDArray[np.float64]:
    """(tiles, 9): how far (m) each tile's 3 × 3 nodes lie from the nearest ground return.
    Beyond a few hundred metres it is capped: the gap term is then large enough to claim nothing.

    Neighbouring tiles share nodes: each node is found once, on a raster of the node lattice over
    the tiles' extent (smaller than the dense model's), and read back by its place. Each return
    first measures the nodes within ``radius`` of it, a few passes over the returns; only the nodes
    left unmeasured, the gaps, need their nearest return searched for. ``tree``:
    :func:`tdb.kdtree.plan_tree` of ``g`` (None where ``g`` is empty)."""
    step = LEVEL // 2
    du, dv = (a.ravel() for a in np.meshgrid([0, 1, 2], [0, 1, 2]))  # in node steps
    cap = max(100.0 * radius, 50.0)
    if len(g) == 0:
        return np.full((len(xg), 9), cap)
    x0, y0 = int(xg.min()), int(yg.min())
    ci, cj = (xg - x0) // step, (yg - y0) // step
    touched = np.zeros((int(cj.max()) + 3, int(ci.max()) + 3), bool)
    rows, cols = cj[:, None] + dv, ci[:, None] + du
    touched[rows, cols] = True
    reach = np.sqrt(_near_nodes(g, touched.shape, (x0, y0), step, radius))
    nj, ni = np.nonzero(touched & ~np.isfinite(reach))
    if len(nj):
        nodes = np.column_stack([x0 + ni * float(step), y0 + nj * float(step)])
        assert tree is not None  # g holds returns here
        d, _ = tree.query(nodes, k=1, distance_upper_bound=cap)
        reach[nj, ni] = np.minimum(d, cap)
    return reach[rows, cols]


def _near_nodes(
    g: NDArray[np.float64], shape: tuple[int, int], origin: tuple[int, int], step: int, radius: float
) -> NDArray[np.float64]:
    """The squared distance (m²) to the nearest return of ``g`` of each node of a lattice
    (``shape``, its first node at ``origin``, ``step`` m apart) that lies within ``radius`` of one
    (inf elsewhere): the nodes near enough to each return, one offset at a time.

    The nearest offsets come first, so that the farther ones lower few nodes and write only
    where they do."""
    near = np.full(shape, np.inf)
    u, v = (g[:, 0] - origin[0]) / step, (g[:, 1] - origin[1]) / step
    i0, j0 = np.floor(u).astype(np.int64), np.floor(v).astype(np.int64)
    reach = int(np.ceil(radius / step))
    r2 = (radius / step) ** 2
    # from the square's own corners outwards (a return lies in the square [i0, i0 + 1) × [j0, j0 + 1)),
    # leaving out the nodes too far from every point of it
    span = range(-reach, reach + 1)
    offsets = sorted(
        ((di, dj) for di in span for dj in span if max(0, -di, di - 1) ** 2 + max(0, -dj, dj - 1) ** 2 <= r2),
        key=lambda o: (o[0] - 0.5) ** 2 + (o[1] - 0.5) ** 2,
    )
    for di, dj in offsets:
        i, j = i0 + di, j0 + dj
        d2 = (i - u) ** 2 + (j - v) ** 2
        hit = np.flatnonzero((d2 <= r2) & (i >= 0) & (j >= 0) & (i < shape[1]) & (j < shape[0]))
        i, j, d2 = i[hit], j[hit], d2[hit] * step**2
        lower = d2 < near[j, i]
        np.minimum.at(near, (j[lower], i[lower]), d2[lower])
    return near
