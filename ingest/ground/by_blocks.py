"""The ground of a survey too wide to filter whole: block by block, as a blocked ingest filters it.

The filter's grids cover its whole extent, filled or not, so a corridor survey or two sites in
one file can need more memory than the machine has although their points fit. Then the points
are cut into the blocks of a lattice (:mod:`ingest.block_lattice`), each block filtered with
:data:`ingest.block_lattice.BUFFER` m of its neighbours' points, its grid over its read box within
the survey's bounds and its outlier test sized to the whole survey's density, and each point
labelled by the block whose square holds it: the ground a blocked ingest finds.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from ingest.block_lattice import BlockLattice
from tdb.bbox import Box
from tdb.cloud import PointCloud
from tdb.progress import Progress, or_silent

# (a block's points, its filter grid's extent) -> their ground mask
BlockFilter = Callable[[PointCloud, Box], NDArray[np.bool_]]


def ground_by_blocks(
    cloud: PointCloud,
    ground_of: BlockFilter,
    *,
    density: float,
    survey: Box,
    progress: Progress | None = None,
    step: str = "ground filter",
) -> NDArray[np.bool_]:
    """Ground mask of ``cloud`` (metres) by ``ground_of`` run block by block over ``survey``
    (x0, y0, x1, y1, holding every point), blocks sized to the survey's ``density`` (points per
    m², :func:`ingest.block_size.block_side`); ``progress`` is told ``(step, blocks done, blocks)``."""
    report = or_silent(progress)
    lattice = BlockLattice.over(survey, density=density)
    groups = list(lattice.groups(cloud.x, cloud.y))
    ground = np.zeros(len(cloud), bool)
    for n, (k, part, mine) in enumerate(groups):
        report(step, n, len(groups))
        if mine.any() and len(part) >= 3:
            ground[part[mine]] = ground_of(cloud.take(part), lattice.block(k).extent)[mine]
    report(step, len(groups), len(groups))
    return ground
