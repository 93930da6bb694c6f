"""Change detection over an area too wide to read at once: the tiles that moved, part by part.

Two surveys of a county hold hundreds of millions of tiles each; read at once, their tiles and
the lattices of their kept points fill the memory, and the node lattice over the whole area is
refused. Whether a tile moved depends on its own nodes and ground evidence alone
(:mod:`queries.tile_change`), so it is found part by part (:mod:`queries.parts`), every tile
both versions hold with data tested. Only the tiles that moved are kept: few beside the tiles.
The regions are then grown and typed from them (:func:`queries.changes.detect`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from queries.coregister import Shift, shifted_lattice
from queries.grids import shared_tiles
from queries.parts import Box, clipped, holds
from queries.tile_change import MovingTiles, Sides, tile_lattice, tile_lod
from tdb.categories import NO_DATA
from tdb.database import Database
from tdb.progress import Progress, or_silent
from tdb.tiles import TileIndex
from tdb.workers import on_database

NEIGHBOURS = np.array([(di, dj) for di in (-1, 0, 1) for dj in (-1, 0, 1) if di or dj])


@dataclass(frozen=True)
class MovedTiles:
    """The tiles of a level whose surface moved beyond their level of detection: lower-left
    corners, the height change at their 3 × 3 nodes (tiles × 9), their LoD, what each version's
    ground evidence says of them (:class:`queries.tile_change.Sides`), and whether their
    category differs (the tiles a change starts from)."""

    xg: NDArray[np.int64]
    yg: NDArray[np.int64]
    dz: NDArray[np.float64]
    lod: NDArray[np.float64]
    sides: Sides
    differ: NDArray[np.bool_]

    @property
    def layer(self) -> NDArray[np.float64]:
        """(2, tiles) m: the layer each version's surface lies in."""
        return self.sides.layer

    @staticmethod
    def joined(parts: list[MovedTiles]) -> MovedTiles:
        """The tiles of ``parts`` as one record (none where no part holds any)."""
        if not parts:
            none = np.zeros(0, np.int64)
            return MovedTiles(none, none, np.zeros((0, 9)), np.zeros(0), Sides.empty(), np.zeros(0, bool))
        cat = np.concatenate
        return MovedTiles(
            cat([p.xg for p in parts]),
            cat([p.yg for p in parts]),
            cat([p.dz for p in parts]),
            cat([p.lod for p in parts]),
            Sides.joined([p.sides for p in parts]),
            cat([p.differ for p in parts]),
        )


def moved_by_parts(  # noqa: PLR0913 (the two versions, where, and how)
    db: Database,
    before: str,
    after: str,
    *,
    level: int,
    bbox: Box | None,
    parts: list[Box],
    lod: float,
    shift: Shift | None = None,
    progress: Progress | None = None,
    workers: int | None = None,
) -> MovedTiles:
    """The tiles both versions hold with data at ``level`` in ``bbox`` whose surface moved beyond
    their level of detection (at least ``lod``), ``after`` aligned by ``shift``, found in ``parts``
    (:func:`queries.parts.part_boxes`), in ``workers`` processes (:func:`tdb.workers.on_database`;
    None: one per core)."""
    report = or_silent(progress)
    jobs = [_Part(before, after, part, level, bbox, lod, shift) for part in parts]
    found = []
    report("parts", 0, len(parts))
    for k, moved in enumerate(on_database(_moved_in, db, jobs, workers=workers, preload=__name__)):
        found.append(moved)
        report("parts", k + 1, len(parts))
    return MovedTiles.joined([f for f in found if f is not None])


@dataclass(frozen=True)
class _Part:
    """One part of a diff by parts, and how its tiles are judged."""

    before: str
    after: str
    box: Box
    level: int
    bbox: Box | None
    lod: float
    shift: Shift | None


def _moved_in(db: Database, job: _Part) -> MovedTiles | None:
    level, before, after = job.level, job.before, job.after
    xg, yg, c1, c2 = shared_tiles(db, before, after, level=level, bbox=clipped(job.box, job.bbox))
    mine = holds(job.box, xg, yg) & (c1 != NO_DATA) & (c2 != NO_DATA)
    if not mine.any():
        return None
    xg, yg, differ = xg[mine], yg[mine], (c1 != c2)[mine]
    lattices = [tile_lattice(db, name, level, xg, yg) for name in (before, after)]
    if job.shift is not None and job.shift.applied:
        lattices[1] = shifted_lattice(lattices[1], job.shift)
    judged = tile_lod(db, before, after, xg, yg, level=level, lod=job.lod)
    tested, dz, lod, moved = MovingTiles(xg, yg, lattices[0], lattices[1], judged).moved(np.arange(len(xg)))
    t = tested[moved]
    return MovedTiles(xg[t], yg[t], dz[moved], lod[moved], judged.sides.take(t), differ[t])


def reached(xg: NDArray[np.int64], yg: NDArray[np.int64], seeds: NDArray[np.intp], level: int) -> NDArray[np.intp]:
    """The tiles (indices, ascending) that touch ``seeds`` through a chain of the tiles ``xg``,
    ``yg`` (8-neighbours on the tile lattice): the seeds grown over every tile that moved beside
    them, ring by ring, until none is added."""
    if len(seeds) == 0:
        return np.zeros(0, np.intp)
    ti, tj = xg // level, yg // level
    index = TileIndex(ti, tj)
    rows, cols = [], []
    for di, dj in NEIGHBOURS:
        other = index.find(ti + di, tj + dj)
        k = np.flatnonzero(other >= 0)
        rows.append(k)
        cols.append(other[k])
    r, c = np.concatenate(rows), np.concatenate(cols)
    graph = coo_matrix((np.ones(len(r)), (r, c)), shape=(len(xg), len(xg)))
    _, label = connected_components(graph, directed=False)
    return np.flatnonzero(np.isin(label, np.unique(label[seeds])))
