"""Plane tiles that face each other across a shared edge: the two banks of a form on a tile edge.

A ditch wider than a tile whose bottom runs along tile edges puts no valley in any
tile: the tiles on either side each hold one bank, a single inclined plane. Such a
pair still says "valley here": the two planes fall towards each other across their
shared edge (for a ridge or a wall they rise towards each other).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tdb.categories import DIRECTION_VECTORS, NONE, by_code
from tdb.tiles import TileIndex

_INCLINATION = by_code("inclination", missing=0)
_FEATURE = by_code("feature")
_FACING = 0.5  # cosine: a plane's slope points across the shared edge, within 45° of it


def facing_planes(
    xg: NDArray[np.int64], yg: NDArray[np.int64], code: NDArray[np.uint8], *, level: int, falling: bool = True
) -> NDArray[np.bool_]:
    """Which tiles are inclined planes facing an edge neighbour that is one too.

    Parameters
    ----------
    xg, yg : lower-left tile corners (m), multiples of ``level``.
    code : category codes.
    level : tile size (m).
    falling : True: the two planes fall towards each other (a valley on the edge);
        False: they rise towards each other (a crest on the edge).
    """
    code = np.asarray(code)
    plane = (_FEATURE[code] == NONE) & (_INCLINATION[code] > 0)
    rise = np.zeros((len(code), 2))
    rise[plane] = DIRECTION_VECTORS[_INCLINATION[code[plane]] - 1]
    toward = -rise if falling else rise  # the way each plane leads
    i, j = np.asarray(xg) // level, np.asarray(yg) // level
    index = TileIndex(i, j)
    out = np.zeros(len(code), bool)
    for di, dj in ((1, 0), (0, 1)):  # each neighbour pair once; both tiles are marked
        other = index.find(i + di, j + dj)
        pair = np.flatnonzero(plane & (other >= 0))
        pair = pair[plane[other[pair]]]
        step = np.array([di, dj], float)
        ok = (toward[pair] @ step > _FACING) & (toward[other[pair]] @ -step > _FACING)
        out[pair[ok]] = True
        out[other[pair[ok]]] = True
    return out
