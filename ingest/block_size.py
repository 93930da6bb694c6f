"""What modelling an area costs in memory, and so the side of a blocked ingest's blocks.

A worker's peak memory grows with its block's read box (the block and its buffer): the dense
model's posts, the filter's grids and the tiles by area, whatever the density, and the points by
their number (the triangulation of the ground points above all). Measured by
``benchmarks/block_memory.py``: read boxes of a sparse real survey (FSite5, 0.3 points/m²) and
of synthetic surveys at 2 and 12 pulses/m², each modelled in a fresh process, its peak less its
own before the block. Large blocks waste least on buffers, so a sparse survey keeps
:data:`MAX_BLOCK`; a dense one gets blocks small enough for :data:`WORKER_MEMORY`.

A survey modelled whole is one read box, its extent. The grids cover the whole extent, whether
points fill it or not: a corridor survey, or two patches kilometres apart in one file, costs as
much as the full box. So before a whole model starts, its cost is checked against the machine's
memory (:func:`check_fits`), and the ground filter's alone where only the ground is wanted.
"""

from __future__ import annotations

import math

from tdb.errors import InputError, Remedy
from tdb.memory import physical_bytes
from tdb.tiles import LEVELS

MAX_BLOCK = 512.0  # m: the largest side (a multiple of the coarsest tile, 16 m)
MIN_BLOCK = 64.0  # m: the smallest, where the buffers already read nine times the block
WORKER_MEMORY = 1.5 * 2**30  # bytes one worker may take at its peak
WORKER_BASE = 130 * 2**20  # bytes: a worker before its first block (its modules)
BYTES_PER_M2 = 440.0  # of a block's read box: posts, grids and tiles
BYTES_PER_POINT = 380.0  # of the points read, with a margin for a worker's later blocks
# The ground filter alone (its 1 m grids and passes), from `tdb ground` on FSite5 and on a
# synthetic square kilometre at 2 pulses/m², with a margin.
GROUND_BYTES_PER_M2 = 150.0
GROUND_BYTES_PER_POINT = 350.0


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


def ground_bytes(area: float, points: float) -> float:
    """Bytes the ground filter's peak rises by to filter ``points`` over ``area`` m² whole."""
    return GROUND_BYTES_PER_M2 * area + GROUND_BYTES_PER_POINT * points


def fits(need: float, *, memory: int | None = None) -> bool:
    """Whether ``need`` bytes fit ``memory`` (default: the machine's physical memory; anything fits
    where the system does not say)."""
    memory = physical_bytes() if memory is None else memory
    return not memory or need <= memory


def check_fits(need: float, *, what: str, area: float, memory: int | None = None) -> None:
    """Refuse, before any work, to model ``what`` whole where it needs ``need`` bytes (from
    :func:`block_bytes` or :func:`ground_bytes`, over ``area`` m²) and the machine has less
    (``memory`` bytes; default its physical memory, where the system says).

    Raises
    ------
    InputError
        If ``need`` exceeds ``memory``; its remedy is to model the survey block by block.
    """
    memory = physical_bytes() if memory is None else memory
    if not fits(need, memory=memory):
        raise InputError(
            f"{what}: modelling its {area / 1e6:,.1f} km² extent whole needs about {need / 2**30:,.0f} GiB, "
            f"more than this machine's {memory / 2**30:,.0f} GiB (the grids cover the whole extent, "
            "filled or not); model it block by block",
            remedy=Remedy.BLOCKS,
        )
