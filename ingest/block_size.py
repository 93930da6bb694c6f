"""The side of a blocked ingest's blocks: as large as a worker can model within its memory.

A worker's peak memory grows with its block's read box (the block and its buffer): the dense
model's posts, the filter's grids and the tiles by area, whatever the density, and the points by
their number (the triangulation of the ground points above all). Measured by
``benchmarks/block_memory.py``: read boxes of a sparse real survey (FSite5, 0.3 points/m²) and
of synthetic surveys at 2 and 12 pulses/m², each modelled in a fresh process, its peak less its
own before the block. Large blocks waste least on buffers, so a sparse survey keeps
:data:`MAX_BLOCK`; a dense one gets blocks small enough for :data:`WORKER_MEMORY`.
"""

from __future__ import annotations

import math

from tdb.tiles import LEVELS

MAX_BLOCK = 512.0  # m: the largest side (a multiple of the coarsest tile, 16 m)
MIN_BLOCK = 64.0  # m: the smallest, where the buffers already read nine times the block
WORKER_MEMORY = 1.5 * 2**30  # bytes one worker may take at its peak
WORKER_BASE = 130 * 2**20  # bytes: a worker before its first block (its modules)
BYTES_PER_M2 = 440.0  # of a block's read box: posts, grids and tiles
BYTES_PER_POINT = 380.0  # of the points read, with a margin for a worker's later blocks


def block_side(density: float, *, buffer: float) -> float:
    """The side (m) of the blocks for a survey of ``density`` points/m² with ``buffer`` m around
    each: the largest multiple of the coarsest tile whose read box a worker models within
    :data:`WORKER_MEMORY`, between :data:`MIN_BLOCK` and :data:`MAX_BLOCK`."""
    coarsest = float(max(LEVELS))
    per_m2 = block_bytes(1.0, max(density, 0.0))
    reach = math.sqrt((WORKER_MEMORY - WORKER_BASE) / per_m2)  # the read box's side
    side = math.floor((reach - 2 * buffer) / coarsest) * coarsest
    return float(min(MAX_BLOCK, max(MIN_BLOCK, side)))


def block_bytes(area: float, points: float) -> float:
    """Bytes a worker's peak rises by to model a read box of ``area`` m² holding ``points``."""
    return BYTES_PER_M2 * area + BYTES_PER_POINT * points
