"""The blocks of a blocked ingest: squares of one side on a lattice over the survey's area.

A survey's area can be vast and mostly empty: a corridor along a road or a river, two sites in
one file, or a stray point kilometres off. So the blocks are not laid out one by one: a block is
its index on the lattice, worked out when needed (:meth:`BlockLattice.block`), and the points
find the blocks whose buffered boxes hold them by arithmetic (:meth:`BlockLattice.holding`). The
cost is the points', whatever the area.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ingest.block_size import block_side
from tdb.bbox import Box, clip_bbox
from tdb.blocks import group_starts
from tdb.objects import Building, Tree

BUFFER = 64.0  # m of their neighbours' points the blocks read: the ground filter's reach (ingest.blocked)


@dataclass(frozen=True)
class Block:
    """One block's square (x0, y0, x1, y1) and the box its points are read from; ``closed``: whether
    its east and north edges are the survey's (its kept points there are its own); ``extent``: the
    box its ground filter's grid covers, the read box within the survey's bounds (where the
    whole survey's grid would end too)."""

    core: Box
    grown: Box
    closed: tuple[bool, bool]
    extent: Box

    def owns(self, x: float, y: float) -> bool:
        """Whether (x, y) lies in the block's square (west and south edges included): an object
        is kept by the block its top or centroid is in, so by one block only."""
        return self.core[0] <= x < self.core[2] and self.core[1] <= y < self.core[3]

    def kept(self, trees: list[Tree], buildings: list[Building]) -> tuple[list[Tree], list[Building]]:
        """The trees whose top and the buildings whose centroid lie in the block's square."""
        return (
            [t for t in trees if self.owns(t.x, t.y)],
            [b for b in buildings if self.owns(b.footprint.centroid.x, b.footprint.centroid.y)],
        )


@dataclass(frozen=True)
class BlockLattice:
    """Blocks of ``side`` m over ``area`` (x0, y0, x1, y1), the first with its south-west corner on
    the lattice of the side at or below the area's; block ``k`` is column ``k // rows`` (west to
    east) and row ``k % rows`` (south to north). With ``cut`` (a region) the squares are cut to the
    area. Each reads ``buffer`` m around its square, within the ``survey``'s bounds."""

    area: Box
    side: float
    buffer: float
    survey: Box
    cut: bool = False

    @property
    def origin(self) -> tuple[float, float]:
        return float(np.floor(self.area[0] / self.side) * self.side), float(
            np.floor(self.area[1] / self.side) * self.side
        )

    @property
    def columns(self) -> int:
        return len(np.arange(self.origin[0], self.area[2] + 1e-9, self.side))

    @property
    def rows(self) -> int:
        return len(np.arange(self.origin[1], self.area[3] + 1e-9, self.side))

    @classmethod
    def over(cls, survey: Box, *, density: float, buffer: float = BUFFER) -> BlockLattice:
        """The blocks over a whole survey's box, as large as a worker models at its ``density``
        (points per m², :func:`ingest.block_size.block_side`)."""
        return cls(survey, block_side(density, buffer=buffer), buffer, survey)

    def __len__(self) -> int:
        return self.columns * self.rows

    def block(self, k: int) -> Block:
        """Block ``k``."""
        i, j = divmod(int(k), self.rows)
        x0, y0, x1, y1 = self._cores(np.array([i]), np.array([j]))
        core = (float(x0[0]), float(y0[0]), float(x1[0]), float(y1[0]))
        grown = (core[0] - self.buffer, core[1] - self.buffer, core[2] + self.buffer, core[3] + self.buffer)
        extent = clip_bbox(grown, self.survey, what="the survey")
        return Block(core, grown, (core[2] >= self.area[2], core[3] >= self.area[3]), extent)

    def cores(self) -> Box:
        """The box the blocks' squares cover together."""
        first, last = self.block(0), self.block(len(self) - 1)
        return (first.core[0], first.core[1], last.core[2], last.core[3])

    def extents(self) -> Box:
        """The box the blocks' filter grids cover together: where a one-piece grid ends."""
        first, last = self.block(0), self.block(len(self) - 1)
        return (first.extent[0], first.extent[1], last.extent[2], last.extent[3])

    def holding(
        self, x: NDArray[np.float64], y: NDArray[np.float64]
    ) -> tuple[NDArray[np.int64], NDArray[np.intp], NDArray[np.bool_]]:
        """Every (block, point) pair where the block's read box holds the point (edges included),
        by block and then by point: the blocks ``k``, the points' indices, and whether the point
        lies in the block's own square (west and south edges included, east and north not)."""
        x0, y0 = self.origin
        i = np.floor((x - x0) / self.side).astype(np.int64)
        j = np.floor((y - y0) / self.side).astype(np.int64)
        # a square's buffer reaches this many squares on: one more where it is a whole number of them
        reach = int(self.buffer // self.side) + 1
        blocks, points, own = [], [], []
        index = np.arange(len(x))
        for di in range(-reach, reach + 1):
            for dj in range(-reach, reach + 1):
                bi, bj = i + di, j + dj
                on = (bi >= 0) & (bi < self.columns) & (bj >= 0) & (bj < self.rows)
                if not on.any():
                    continue
                cx0, cy0, cx1, cy1 = self._cores(bi[on], bj[on])
                px, py = x[on], y[on]
                b = self.buffer
                held = (px >= cx0 - b) & (px <= cx1 + b) & (py >= cy0 - b) & (py <= cy1 + b)
                blocks.append((bi[on] * self.rows + bj[on])[held])
                points.append(index[on][held])
                own.append(((px >= cx0) & (px < cx1) & (py >= cy0) & (py < cy1))[held])
        if not blocks:
            return np.zeros(0, np.int64), np.zeros(0, np.intp), np.zeros(0, bool)
        k, p, o = np.concatenate(blocks), np.concatenate(points), np.concatenate(own)
        order = np.lexsort((p, k))
        return k[order], p[order], o[order]

    def groups(
        self, x: NDArray[np.float64], y: NDArray[np.float64], *, skip: NDArray[np.int64] | None = None
    ) -> Iterator[tuple[int, NDArray[np.intp], NDArray[np.bool_]]]:
        """Per block holding points (:meth:`holding`), but those of ``skip``: the block, its points'
        indices in order, and which of them lie in its own square."""
        k, at, own = self.holding(x, y)
        if skip is not None and len(skip):
            keep = ~np.isin(k, skip)
            k, at, own = k[keep], at[keep], own[keep]
        starts = group_starts(k, k)
        for s, e in zip(starts, np.r_[starts[1:], len(k)]):
            yield int(k[s]), at[s:e], own[s:e]

    def _cores(
        self, i: NDArray[np.int64], j: NDArray[np.int64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """The squares (x0, y0, x1, y1) of the blocks in column ``i`` and row ``j``."""
        ox, oy = self.origin
        x0 = ox + i.astype(np.float64) * self.side
        y0 = oy + j.astype(np.float64) * self.side
        x1, y1 = x0 + self.side, y0 + self.side
        if self.cut:
            ax0, ay0, ax1, ay1 = self.area
            x0, y0, x1, y1 = np.maximum(x0, ax0), np.maximum(y0, ay0), np.minimum(x1, ax1), np.minimum(y1, ay1)
        return x0, y0, x1, y1
