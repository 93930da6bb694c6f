"""Filling a raster by straight lines again after a few of its cells changed.

The default filter's refinement fills the ground surface's holes once a pass, and
after the first passes only a few thousand of a million cells change. A hole's
row line depends only on its run of holes along the row and the two filled cells
that close it (likewise for the column), so only the runs that hold or touch a
changed cell are filled again.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from tdb.fill import across_rows, lines_at_holes, weighted_lines


def touched_runs(raster: NDArray[np.floating[Any]], changed: NDArray[np.intp]) -> NDArray[np.intp]:
    """Flat indices (ascending) of the holes of a 2-D raster in the runs along its rows that
    hold a cell of ``changed`` (flat indices) or end beside one."""
    cols = raster.shape[1]
    flat = raster.ravel()
    hole = np.isnan(flat[changed])
    beside = np.concatenate([changed[~hole] - 1, changed[~hole] + 1])
    same_row = (beside // cols == np.tile(changed[~hole] // cols, 2)) & (beside >= 0) & (beside < flat.size)
    beside = beside[same_row]
    probes = np.unique(np.concatenate([changed[hole], beside[np.isnan(flat[beside])]]))
    if len(probes) == 0:
        return probes
    # the filled cells, with a sentinel either end so every probe has both neighbours
    filled = np.r_[-1, np.flatnonzero(~np.isnan(flat)), flat.size]
    k = np.searchsorted(filled, probes)
    row_start = probes // cols * cols
    left, right = filled[k - 1], filled[k]
    start = np.maximum(left + 1, row_start)
    start, first = np.unique(start, return_index=True)
    end = np.minimum(right[first], row_start[first] + cols)
    length = end - start
    return np.repeat(start - np.r_[0, np.cumsum(length)[:-1]], length) + np.arange(length.sum())


class LineFill:
    """:func:`tdb.fill.fill_lines` of a 2-D raster that changes a little from call
    to call, the same to the bit.

    Each call compares the raster with the last one and fills again the runs of holes, along
    rows and columns, that a changed cell lies in or closes; where more than ``full_share``
    of the cells changed it fills the whole raster. It keeps six rasters of the last call.
    """

    def __init__(self, *, full_share: float = 0.05, max_gap: float = np.inf) -> None:
        self.full_share = full_share
        self.max_gap = max_gap
        self._last: NDArray[np.floating[Any]] | None = None
        # the last output and each hole's row and column line (value, gap), flat
        empty: NDArray[np.floating[Any]] = np.zeros(0)
        self._out = self._v_row = self._g_row = self._v_col = self._g_col = empty

    def __call__(self, raster: NDArray[np.floating[Any]]) -> NDArray[np.floating[Any]]:
        last = self._last
        if last is None or last.shape != raster.shape or last.dtype != raster.dtype:
            return self._full(raster)
        same = (raster == last) | (np.isnan(raster) & np.isnan(last))
        changed = np.flatnonzero(~same)
        if len(changed) > self.full_share * raster.size:
            return self._full(raster)
        rows, cols = raster.shape
        at_rows = touched_runs(raster, changed)
        v, g = across_rows(raster, at_rows)
        self._v_row[at_rows], self._g_row[at_rows] = v, g
        turned = np.ascontiguousarray(raster.T)
        r, c = np.divmod(changed, cols)
        at_turned = touched_runs(turned, np.sort(c * rows + r))
        v, g = across_rows(turned, at_turned)
        c, r = np.divmod(at_turned, rows)
        at_cols = r * cols + c
        self._v_col[at_cols], self._g_col[at_cols] = v, g
        out = self._out
        out[changed] = raster.ravel()[changed]
        redo = np.union1d(at_rows, at_cols)
        out[redo] = weighted_lines(
            self._v_row[redo], self._g_row[redo], self._v_col[redo], self._g_col[redo], max_gap=self.max_gap
        )
        self._last = raster.copy()
        return out.reshape(raster.shape).copy()

    def _full(self, raster: NDArray[np.floating[Any]]) -> NDArray[np.floating[Any]]:
        holes, *lines = lines_at_holes(raster)
        kept = [np.full(raster.size, np.nan, raster.dtype) for _ in lines]
        for whole, at_holes in zip(kept, lines):
            whole[holes] = at_holes
        self._v_row, self._g_row, self._v_col, self._g_col = kept
        out = raster.copy().ravel()
        out[holes] = weighted_lines(*lines, max_gap=self.max_gap)
        self._last, self._out = raster.copy(), out
        return out.reshape(raster.shape).copy()
