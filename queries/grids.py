"""Two versions' rebuilt surfaces on one grid of the level's sub-grid nodes.

Each version's surface is rebuilt tile by tile from the points it keeps (the line rebuild of
:mod:`tdb.surface`, as change detection compares it), so a node's value depends on its own tile
alone: the same whatever box it is read in. Nodes of tiles that either version lacks, or holds as
no data, stay no data rather than an interpolation across the gap.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from queries.parts import clipped, fits_at_once, holds, part_side, parts_for
from tdb.categories import NO_DATA
from tdb.database import Database
from tdb.errors import InputError
from tdb.raster import MAX_CELLS, Raster
from tdb.surface import line_rebuild_at
from tdb.tiles import SUBGRID, node_lattice, node_spacing, tile_key

Box = tuple[float, float, float, float]
BLOCK = 16  # m: the blocks a sample of the area is taken in


def shared_tiles(
    db: Database, before: str, after: str, *, level: int, bbox: tuple[float, float, float, float] | None
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.uint8], NDArray[np.uint8]]:
    """(xg, yg) of the tiles both versions hold at ``level`` in ``bbox``, and each one's code in either."""
    xa, ya, ca = db.tiles(before, level=level, bbox=bbox, ordered=False)
    xb, yb, cb = db.tiles(after, level=level, bbox=bbox, ordered=False)
    _, ia, ib = np.intersect1d(tile_key(xa, ya), tile_key(xb, yb), return_indices=True)
    return xa[ia], ya[ia], ca[ia], cb[ib]


def surface_grids(  # noqa: PLR0913 (the two versions, where, and how finely)
    db: Database,
    before: str,
    after: str,
    *,
    level: int = 2,
    bbox: Box | None = None,
    max_cells: int = MAX_CELLS // 10,
    fit: bool = False,
    blocks: int = 1,
) -> tuple[Raster, Raster]:
    """Both versions' rebuilt surfaces on one grid of the level's sub-grid nodes, as
    the module describes (NaN outside the tiles both hold); a grid over ``max_cells`` raises an
    :class:`InputError`, or with ``fit`` keeps every k-th node. With ``blocks`` k > 1 only one
    16 m block in k is rebuilt (diagonal stripes of whole blocks, so slopes inside them hold)."""
    xg, yg = _held_tiles(db, before, after, level=level, bbox=bbox, blocks=blocks)
    if len(xg) == 0:
        raise InputError(f"versions {before!r} and {after!r} share no tiles at level {level} there")
    s = node_spacing(level)
    x0, y0, x1, y1 = bbox or (float(xg.min()), float(yg.min()), float(xg.max() + level), float(yg.max() + level))
    i0, j0 = int(np.ceil(x0 / s - 1e-9)), int(np.ceil(y0 / s - 1e-9))
    i1, j1 = int(np.floor(x1 / s + 1e-9)), int(np.floor(y1 / s + 1e-9))
    step = 1
    cells = (i1 - i0 + 1) * (j1 - j0 + 1)
    if cells > max_cells and fit:
        step = int(np.ceil(np.sqrt(cells / max_cells)))
        cells = ((i1 - i0) // step + 1) * ((j1 - j0) // step + 1)
    if cells > max_cells:
        raise InputError(
            f"a {s} m difference grid over this area needs {cells:,} cells (most {max_cells:,}); "
            "give a smaller bbox"
        )
    grown = (float(xg.min()), float(yg.min()), float(xg.max() + level), float(yg.max() + level))
    # Tile origins lie on every (SUBGRID − 1)-th node, so the sub-grid nodes that fall on the grid
    # are the same in every tile: only those are rebuilt. Neighbours share their edge nodes.
    d = np.arange(SUBGRID)
    on_x = d[(np.rint(xg[0] / s).astype(np.int64) + d - i0) % step == 0]
    on_y = d[(np.rint(yg[0] / s).astype(np.int64) + d - j0) % step == 0]
    cells = (on_y[:, None] * SUBGRID + on_x[None, :]).ravel()
    ni = np.rint(xg / s).astype(np.int64)[:, None] + np.tile(on_x, len(on_y))[None, :]
    nj = np.rint(yg / s).astype(np.int64)[:, None] + np.repeat(on_y, len(on_x))[None, :]
    rows, cols = (j1 - j0) // step + 1, (i1 - i0) // step + 1
    ci, cj = (ni - i0) // step, (nj - j0) // step
    ok = (ci >= 0) & (cj >= 0) & (ci < cols) & (cj < rows)
    cell = s * step
    out = []
    for version in (before, after):
        grid = np.full((rows, cols), np.nan)
        grid[rows - 1 - cj[ok], ci[ok]] = _surface(db, version, level, xg, yg, grown, cells)[ok]  # north first
        out.append(Raster(grid, i0 * s - cell / 2, (j0 + (rows - 1) * step) * s + cell / 2, cell, db.crs(version)))
    return out[0], out[1]


def _held_tiles(
    db: Database, before: str, after: str, *, level: int, bbox: Box | None, blocks: int
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """(xg, yg) of the tiles both versions hold with data at ``level`` in ``bbox``, one 16 m block
    in ``blocks`` of them: read part by part (:mod:`queries.parts`) where the area is too wide to
    read at once, so that only the tiles kept are held."""
    parts = parts_for(db, before, level=level, bbox=bbox)
    if not parts:
        return _held(*shared_tiles(db, before, after, level=level, bbox=bbox), blocks=blocks)
    out = []
    for part in parts:
        xg, yg, ca, cb = shared_tiles(db, before, after, level=level, bbox=clipped(part, bbox))
        mine = holds(part, xg, yg)
        out.append(_held(xg[mine], yg[mine], ca[mine], cb[mine], blocks=blocks))
    return np.concatenate([x for x, _ in out]), np.concatenate([y for _, y in out])


def _held(
    xg: NDArray[np.int64], yg: NDArray[np.int64], ca: NDArray[np.uint8], cb: NDArray[np.uint8], *, blocks: int
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    held = (ca != NO_DATA) & (cb != NO_DATA)
    if blocks > 1:
        held &= (xg // BLOCK + yg // BLOCK) % blocks == 0
    return xg[held], yg[held]


def _surface(db: Database, version: str, level: int, xg: Any, yg: Any, box: Box, cells: Any) -> np.ndarray:
    """The version's rebuilt surface at the flat sub-grid indices ``cells`` of each tile (T, len(cells)).

    A tile's nodes come from its own points alone, so where the tiles' box would hold a lattice of
    more than :data:`queries.parts.PART_NODES` nodes (a version spread over a vast, mostly empty
    box) they are rebuilt part by part, each part's points read on their own."""
    if fits_at_once(box, level):
        parts = [np.arange(len(xg))]
    else:
        side = part_side(level)
        key = tile_key(np.asarray(xg) // side, np.asarray(yg) // side)
        order = np.argsort(key, kind="stable")
        parts = np.split(order, np.flatnonzero(np.diff(key[order])) + 1)
    out = np.empty((len(xg), len(cells)))
    for part in parts:
        px, py = xg[part], yg[part]
        where = (float(px.min()), float(py.min()), float(px.max() + level), float(py.max() + level))
        x, y, z, _ = db.points(version, level=level, bbox=where, ordered=False)
        out[part] = line_rebuild_at(node_lattice(x, y, z, level).tile_nodes(px, py), cells)
    return out
