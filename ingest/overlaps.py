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
from tdb.bbox import boxes_meeting

KEY_M = 1e-3  # positions equal to this are one point: tiles written with other scales still agree


class SharedPoints:
    """Reads a catalog's tiles in order, as chunks, and drops from each chunk the points an
    earlier tile holds (:meth:`__call__`); ``dropped`` counts them. A tile's remembered points are
    let go once the last tile that overlaps it has been read."""

    def __init__(self, bounds: Sequence[Box]) -> None:
        self.bounds = np.array(bounds, np.float64).reshape(-1, 4)
        self._near: dict[int, NDArray[np.intp]] = {}
        self._held: dict[int, list[NDArray[Any]]] = {}
        self.dropped = 0

    def __call__(self, tile: int, rec: NDArray[Any]) -> NDArray[Any]:
        """``rec``, a chunk of tile ``tile``'s points (``RECORD`` rows), without those an earlier
        tile holds; its points that a later tile may hold again are remembered."""
        for j in [j for j in self._held if self._overlapping(j).max(initial=j) < tile]:
            del self._held[j]
        near = self._overlapping(tile)
        twice = np.zeros(len(rec), bool)
        for j in near[near < tile]:
            if int(j) in self._held:
                inside = np.flatnonzero(in_box(rec, self._box(j)))
                if len(inside):
                    twice[inside[np.isin(_keys(rec[inside]), self._keys_of(int(j)))]] = True
        if twice.any():
            rec = rec[~twice]
            self.dropped += int(twice.sum())
        later = near[near > tile]
        if len(later) and len(rec):
            shared = np.logical_or.reduce([in_box(rec, self._box(j)) for j in later])
            if shared.any():
                self._held.setdefault(tile, []).append(_keys(rec[shared]))
        return rec

    def _overlapping(self, tile: int) -> NDArray[np.intp]:
        """The other tiles whose bounds meet ``tile``'s (edges included), found once per tile."""
        if tile not in self._near:
            meet = boxes_meeting(self.bounds, self._box(tile))
            self._near[tile] = meet[meet != tile]
        return self._near[tile]

    def _box(self, tile: Any) -> Box:
        x0, y0, x1, y1 = self.bounds[int(tile)].tolist()
        return (x0, y0, x1, y1)

    def _keys_of(self, tile: int) -> NDArray[Any]:
        held = self._held[tile]
        if len(held) > 1:
            held[:] = [np.concatenate(held)]
        return held[0]


def _keys(rec: NDArray[Any]) -> NDArray[Any]:
    """One comparable value per point: its position in millimetres and its return number."""
    cols = [np.round(rec[a] / KEY_M).astype(np.int64) for a in "xyz"] + [rec["r"].astype(np.int64)]
    return np.ascontiguousarray(np.column_stack(cols)).view(np.dtype((np.void, 32))).ravel()
