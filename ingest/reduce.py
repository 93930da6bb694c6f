"""Data reduction: keep the tile corners and the sub-grid nodes of each tile's feature.

Kept nodes of all levels are merged into one set of points; each carries a
4-bit mask n of the levels that keep it (bit 0: 2 m … bit 3: 16 m).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ingest.tiles import LEVELS, NodeGrid
from tdb.categories import NO_DATA, feature_nodes


@dataclass(frozen=True)
class KeptNodes:
    """Kept nodes of one level, as integer node indices in units of the finest spacing."""

    kx: NDArray[np.int64]
    ky: NDArray[np.int64]


def level_bit(level: int) -> int:
    return 1 << LEVELS.index(level)


def kept_nodes(
    grid: NodeGrid, codes: NDArray[np.uint8], ti: NDArray[np.int64], tj: NDArray[np.int64], *, n: int, unit: float
) -> KeptNodes:
    """Corners of every tile with data plus the feature nodes of its category.

    ``unit`` is the finest node spacing; keys are node positions / unit.
    """
    ok = codes != NO_DATA
    keep = np.zeros((int(ok.sum()), n * n), bool)
    keep[:, [0, n - 1, n * (n - 1), n * n - 1]] = True
    keep |= feature_nodes(n)[codes[ok]]
    t_idx, node = np.nonzero(keep)
    ratio = round(grid.spacing / unit)
    step = n - 1
    kx = (ti[ok][t_idx] * step + node % n) * ratio
    ky = (tj[ok][t_idx] * step + node // n) * ratio
    both = np.unique(np.column_stack([kx, ky]), axis=0)
    return KeptNodes(both[:, 0], both[:, 1])
