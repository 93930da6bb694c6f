"""A version too wide to read at once, read in parts: boxes of whole tile blocks where it holds data.

A query over a whole survey of a municipality cannot hold every tile and kept point of it at
once: at the 2 m level that is a quarter of a million tiles and as many points per km². So the
area is cut into parts of about :data:`PART` m, on the database's tile blocks (:mod:`tdb.blocks`),
and only the parts that hold tiles are listed: the empty part of a vast box costs nothing.

A feature query (:func:`queries.match.find`) reads each part's tiles with a margin of one tile,
which is all its candidate tiles depend on (a tile's own category, and for facing planes its
edge neighbours), and keeps the candidates of the part's own tiles. The candidates of all parts
are few beside the tiles; their groups (:func:`queries.filters.components`) are then matched
batch by batch, each batch with the stored points of its box and the reach of its filter. An
object is matched from its own tiles and the points around them alone, so the matches are those
of the whole area read at once.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from queries.filters import Filter, candidates, components, link_reach
from tdb.bbox import box_area
from tdb.blocks import TILES_PER_BLOCK
from tdb.database import Database
from tdb.progress import Progress, or_silent
from tdb.tiles import node_spacing, tile_key

Box = tuple[float, float, float, float]
PART = 1024  # m: the side of a part (whole tile blocks: a block where it is larger)
PART_NODES = 16_000_000  # nodes of the largest lattice read at once (128 MB)


def fits_at_once(box: Box, level: int) -> bool:
    """Whether a lattice of ``level``'s nodes over ``box`` is small enough to read at once."""
    return box_area(box) / node_spacing(level) ** 2 <= PART_NODES


def part_side(level: int) -> int:
    """The side (m) of the parts at ``level``: whole tile blocks, about :data:`PART` m."""
    block = TILES_PER_BLOCK * level
    return max(1, PART // block) * block


def parts_for(db: Database, version: str, *, level: int, bbox: Box | None) -> list[Box]:
    """The parts (:func:`part_boxes`) an area of ``version`` (``bbox``, or all of it) is read in;
    none where it can be read at once: its lattice fits (:func:`fits_at_once`), or it holds tiles
    in one part at most."""
    box = bbox or db.version(version).stats.bounds
    if box is None or fits_at_once(box, level):
        return []
    parts = part_boxes(db, version, level=level, bbox=bbox)
    return parts if len(parts) > 1 else []


def part_boxes(db: Database, version: str, *, level: int, bbox: Box | None = None) -> list[Box]:
    """The squares of :func:`part_side` that hold tiles of ``version`` at ``level`` meeting ``bbox``,
    west to east, then south to north: a tile belongs to the one its lower-left corner lies in."""
    side = part_side(level)
    per = side // (TILES_PER_BLOCK * level)
    bx, by = db.tile_blocks(version, level=level, bbox=bbox)
    if len(bx) == 0:
        return []
    keys = np.unique(np.column_stack([bx // per, by // per]), axis=0)
    return [(float(i * side), float(j * side), float((i + 1) * side), float((j + 1) * side)) for i, j in keys]


@dataclass(frozen=True)
class Candidates:
    """The candidate tiles of a filter over an area (:func:`queries.filters.candidates`): their
    lower-left corners, codes, and whether each is one of the filter's features (``own``) or an
    inclined plane facing another (``facing``)."""

    xg: NDArray[np.int64]
    yg: NDArray[np.int64]
    code: NDArray[np.uint8]
    own: NDArray[np.bool_]
    facing: NDArray[np.bool_]

    def __len__(self) -> int:
        return len(self.xg)

    def take(self, idx: NDArray[np.intp]) -> Candidates:
        return Candidates(self.xg[idx], self.yg[idx], self.code[idx], self.own[idx], self.facing[idx])

    @staticmethod
    def joined(found: list[Candidates]) -> Candidates:
        return Candidates(
            *(np.concatenate([getattr(c, f) for c in found]) for f in Candidates.__dataclass_fields__)
        )


def part_candidates(
    db: Database,
    version: str,
    flt: Filter,
    *,
    level: int,
    bbox: Box | None,
    parts: list[Box],
    progress: Progress | None = None,
) -> Candidates:
    """The candidate tiles of ``flt`` among ``version``'s tiles at ``level`` in ``bbox``, read part
    by part, each part's tiles with a margin of two tiles (the edge neighbours facing planes
    are judged with)."""
    report = or_silent(progress)
    found: list[Candidates] = []
    report("parts", 0, len(parts))
    for k, part in enumerate(parts):
        xg, yg, code = db.tiles(version, level=level, bbox=clipped(_grown(part, 2 * level), bbox), ordered=False)
        own, facing = candidates(xg, yg, code, flt, level)
        mine = (own | facing) & holds(part, xg, yg)
        found.append(Candidates(xg[mine], yg[mine], code[mine], own[mine], facing[mine]))
        report("parts", k + 1, len(parts))
    return Candidates.joined(found)


def batches(
    tiles: Candidates, flt: Filter, *, level: int, grow: float, bbox: Box | None
) -> Iterator[tuple[NDArray[np.intp], Box]]:
    """The candidate tiles in batches of whole groups (:func:`queries.filters.components`), each
    with the box its stored points are read in: its tiles' box grown by ``grow`` (the filter's
    reach), within ``bbox`` grown so, as the area read at once would be. A batch holds the groups
    that start in one part; a group that spans more than a part's worth of nodes is a batch alone."""
    groups = grouped(tiles, flt, level=level)
    if not groups:
        return
    side = part_side(level)
    start = np.array([[tiles.xg[g].min() // side, tiles.yg[g].min() // side] for g in groups])
    _, which = np.unique(start, axis=0, return_inverse=True)
    limit = None if bbox is None else _grown(bbox, grow)
    for b in range(int(which.max()) + 1):
        members = [groups[k] for k in np.flatnonzero(which.ravel() == b)]
        idx = np.concatenate(members)
        box = clipped(_grown(_tiles_box(tiles, idx, level), grow), limit)
        if fits_at_once(box, level) or len(members) == 1:
            yield idx, box
            continue
        for g in members:
            yield g, clipped(_grown(_tiles_box(tiles, g, level), grow), limit)


def line_batches(
    bounds: NDArray[np.float64], *, level: int, grow: float
) -> Iterator[tuple[NDArray[np.intp], Box]]:
    """Lines (their ``bounds``, (N, 4)) in batches read together, each with the box its stored
    points are read in: its lines' box grown by ``grow``. All lines are one batch where that box
    fits (:func:`fits_at_once`), else those whose lower-left corner lies in one part are."""
    if not len(bounds):
        return
    if fits_at_once(_grown(_lines_box(bounds), grow), level):
        which = np.zeros(len(bounds), np.intp)
    else:
        which = np.unique(np.floor(bounds[:, :2] / part_side(level)), axis=0, return_inverse=True)[1].ravel()
    order = np.argsort(which, kind="stable")
    for idx in np.split(order, np.flatnonzero(np.diff(which[order])) + 1):
        yield idx, _grown(_lines_box(bounds[idx]), grow)


def _lines_box(bounds: NDArray[np.float64]) -> Box:
    (x0, y0), (x1, y1) = bounds[:, :2].min(axis=0), bounds[:, 2:].max(axis=0)
    return (float(x0), float(y0), float(x1), float(y1))


def grouped(tiles: Candidates, flt: Filter, *, level: int) -> list[NDArray[np.intp]]:
    """The groups of ``tiles`` that :func:`queries.filters.components` forms under ``flt``, found
    part by part and joined across the parts' edges: the graph of every candidate at once would
    hold a few hundred bytes per candidate, a gigabyte over 70 km² at the 2 m level.

    Two tiles the filter joins directly lie at most :func:`queries.filters.link_reach` tiles apart,
    so where they lie in two parts, both lie that near an edge: the groups of the tiles near the
    parts' edges say which groups of neighbouring parts are one."""
    one = replace(flt, min_tiles=1)
    side = part_side(level)
    part = tile_key(tiles.xg // side, tiles.yg // side)
    order = np.argsort(part, kind="stable")
    starts = np.flatnonzero(np.r_[True, part[order][1:] != part[order][:-1]])
    label = np.empty(len(tiles), np.int64)
    n = 0
    for idx in np.split(order, starts[1:]):
        for g in _components(tiles.take(idx), one, level):
            label[idx[g]] = n
            n += 1
    reach = (link_reach(flt) + 1) * level
    rx, ry = tiles.xg % side, tiles.yg % side
    edge = np.flatnonzero((rx < reach) | (rx >= side - reach) | (ry < reach) | (ry >= side - reach))
    pairs = [
        np.column_stack([np.full(len(g) - 1, label[edge[g[0]]]), label[edge[g[1:]]]])
        for g in _components(tiles.take(edge), one, level)
        if len(g) > 1
    ]
    pair = np.concatenate(pairs) if pairs else np.zeros((0, 2), np.int64)
    graph = coo_matrix((np.ones(len(pair)), (pair[:, 0], pair[:, 1])), shape=(n, n))
    merged = connected_components(graph, directed=False)[1][label] if n else label
    by = np.argsort(merged, kind="stable")
    groups = np.split(by, np.flatnonzero(np.diff(merged[by])) + 1) if len(by) else []
    return [g for g in groups if len(g) >= flt.min_tiles]


def _components(tiles: Candidates, flt: Filter, level: int) -> list[NDArray[np.intp]]:
    return components(tiles.xg, tiles.yg, tiles.code, flt, level, accept=np.ones(len(tiles), bool))


def _tiles_box(tiles: Candidates, idx: NDArray[np.intp], level: int) -> Box:
    x, y = tiles.xg[idx], tiles.yg[idx]
    return (float(x.min()), float(y.min()), float(x.max() + level), float(y.max() + level))


def _grown(box: Box, by: float) -> Box:
    return (box[0] - by, box[1] - by, box[2] + by, box[3] + by)


def holds(part: Box, xg: NDArray[np.int64], yg: NDArray[np.int64]) -> NDArray[np.bool_]:
    """Which tiles (lower-left corners ``xg``, ``yg``) belong to ``part``: those whose corner lies
    in it. A tile lies whole in the part its corner lies in (parts are whole tile blocks)."""
    return (xg >= part[0]) & (xg < part[2]) & (yg >= part[1]) & (yg < part[3])


def clipped(box: Box, limit: Box | None) -> Box:
    """``box`` cut to ``limit`` (``box`` where None)."""
    if limit is None:
        return box
    return (max(box[0], limit[0]), max(box[1], limit[1]), min(box[2], limit[2]), min(box[3], limit[3]))
