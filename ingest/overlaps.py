"""The points that overlapping tiles of a catalog hold twice.

Providers often deliver tiles with a buffer: a strip along each edge holds the neighbours' points
again. Merged as they are, those strips would count every point twice: twice the density, twice
the ground returns a tile's evidence rests on, each tree's returns in both. So a point of a later
tile that an earlier tile of the catalog already holds (the same position to the millimetre and
the same return number) is dropped. Only the points in the overlap of two tiles' header bounds
are compared, so the work and the memory are those of the shared strips, not of the tiles.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ingest.readers import Box, in_box
from tdb.bbox import overlaps

KEY_M = 1e-3  # positions equal to this are one point: tiles written with other scales still agree


class SharedPoints:
    """Reads a catalog's tiles in order, as chunks, and drops from each chunk the points an
    earlier tile holds (:meth:`__call__`); ``dropped`` counts them."""

    def __init__(self, bounds: Sequence[Box]) -> None:
        self.bounds: list[Box] = [(float(b[0]), float(b[1]), float(b[2]), float(b[3])) for b in bounds]
        self._held: list[list[NDArray[Any]]] = [[] for _ in self.bounds]
        self.dropped = 0

    def __call__(self, tile: int, rec: NDArray[Any]) -> NDArray[Any]:
        """``rec``, a chunk of tile ``tile``'s points (``RECORD`` rows), without those an earlier
        tile holds; its points that a later tile may hold again are remembered."""
        twice = np.zeros(len(rec), bool)
        for j in range(tile):
            if self._held[j] and overlaps(self.bounds[j], self.bounds[tile]):
                inside = np.flatnonzero(in_box(rec, self.bounds[j]))
                if len(inside):
                    twice[inside[np.isin(_keys(rec[inside]), self._keys_of(j))]] = True
        if twice.any():
            rec = rec[~twice]
            self.dropped += int(twice.sum())
        later = [b for b in self.bounds[tile + 1 :] if overlaps(self.bounds[tile], b)]
        if later and len(rec):
            shared = np.logical_or.reduce([in_box(rec, b) for b in later])
            if shared.any():
                self._held[tile].append(_keys(rec[shared]))
        return rec

    def _keys_of(self, tile: int) -> NDArray[Any]:
        held = self._held[tile]
        if len(held) > 1:
            held[:] = [np.concatenate(held)]
        return held[0]


def _keys(rec: NDArray[Any]) -> NDArray[Any]:
    """One comparable value per point: its position in millimetres and its return number."""
    cols = [np.round(rec[a] / KEY_M).astype(np.int64) for a in "xyz"] + [rec["r"].astype(np.int64)]
    return np.ascontiguousarray(np.column_stack(cols)).view(np.dtype((np.void, 32))).ravel()
