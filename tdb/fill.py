"""Filling the holes of a raster: nearest value, or straight lines across the gap."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from tdb.errors import InputError
from tdb.threads import one_blas_thread

Lines = NDArray[np.floating[Any]]  # one value per hole


def fill_nearest(
    raster: NDArray[np.floating[Any]], *, where: NDArray[np.bool_] | None = None
) -> NDArray[np.floating[Any]]:
    """Replace NaN cells by the value of the nearest filled cell (of equally near ones, the one
    :func:`scipy.ndimage.distance_transform_edt` picks).

    ``where``: the cells the caller reads (None: all). Where each of them has a filled cell among
    its 8 neighbours, those are filled from the neighbours and the holes farther from any filled
    cell may stay NaN: the same values where asked, without the whole grid's transform.

    Raises
    ------
    InputError
        If the raster has no filled cell.
    """
    holes = _holes_of(raster)
    if holes is None:
        return raster
    near = nearest_cells(holes, where=where)
    if where is None:
        return raster.ravel()[near]
    return np.where(near >= 0, raster.ravel()[np.maximum(near, 0)], np.nan)


def _holes_of(raster: NDArray[np.floating[Any]]) -> NDArray[np.bool_] | None:
    """The raster's NaN cells, None where it has none.

    Raises
    ------
    InputError
        If the raster has no filled cell.
    """
    holes = np.isnan(raster)
    if not holes.any():
        return None
    if holes.all():
        raise InputError("raster has no data to fill from")
    return holes


# The 8 neighbours in the order scipy's feature transform prefers among equally near filled cells:
# the lower column, then the lower row (checked against it cell for cell in the tests).
_NEIGHBOURS = ((0, -1), (-1, 0), (1, 0), (0, 1), (-1, -1), (1, -1), (-1, 1), (1, 1))


def nearest_adjacent(filled: NDArray[np.bool_]) -> NDArray[np.intp]:
    """Per cell of a 2-D mask, the flat index of the nearest filled cell among itself and its 8
    neighbours, as :func:`scipy.ndimage.distance_transform_edt`'s indices pick it (−1 where none
    of the nine is filled): a few shifted comparisons, where the transform costs the whole grid's
    two passes."""
    rows, cols = filled.shape
    cell = np.arange(rows * cols).reshape(rows, cols)
    out = np.where(filled, cell, -1)
    padded = np.pad(filled, 1)
    for dr, dc in _NEIGHBOURS:
        there = padded[1 + dr : 1 + dr + rows, 1 + dc : 1 + dc + cols]
        np.copyto(out, cell + (dr * cols + dc), where=there & (out < 0))
    return out


def nearest_cells(holes: NDArray[np.bool_], *, where: NDArray[np.bool_] | None = None) -> NDArray[np.intp]:
    """The flat index of the nearest filled cell to each cell (itself where filled), as
    :func:`scipy.ndimage.distance_transform_edt`'s indices pick it: from the 8 neighbours where
    every cell of ``where`` (None: every cell) has a filled one, else by the transform. From the
    neighbours, a cell outside ``where`` with none of them filled reads −1."""
    beside = _beside_filled(~holes)
    if (beside if where is None else beside[where]).all():
        return nearest_adjacent(~holes)
    ri, ci = ndimage.distance_transform_edt(holes, return_distances=False, return_indices=True)
    return np.asarray(ri * holes.shape[1] + ci, np.intp)


def _beside_filled(filled: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """The cells that are filled or have a filled 8-neighbour (a 3 × 3 dilation, by rows then
    columns): what tells in a few passes whether :func:`nearest_adjacent` is all a fill needs."""
    p = np.pad(filled, 1)
    across = p[:, :-2] | p[:, 1:-1] | p[:, 2:]
    return across[:-2] | across[1:-1] | across[2:]


class NearestFill:
    """:func:`fill_nearest` for a run of rasters whose holes are mostly the same (the default
    filter's refinement passes): the nearest-cell indices of the last hole mask are kept, because
    the distance transform is the cost."""

    def __init__(self) -> None:
        self._holes: NDArray[np.bool_] | None = None
        self._index: NDArray[np.intp] | None = None

    def __call__(self, raster: NDArray[np.floating[Any]]) -> NDArray[np.floating[Any]]:
        holes = _holes_of(raster)
        if holes is None:
            return raster
        if self._index is None or self._holes is None or not np.array_equal(self._holes, holes):
            self._holes, self._index = holes, nearest_cells(holes)
        return raster.ravel()[self._index]


def across_rows(
    raster: NDArray[np.floating[Any]], holes: NDArray[np.intp]
) -> tuple[NDArray[np.floating[Any]], NDArray[np.floating[Any]]]:
    """At the holes of a 2-D raster (flat indices, ascending), the straight line along the row
    between the filled cells either side, and that gap's length (NaN and inf where the row has
    no filled cell on one side)."""
    cols = raster.shape[1]
    flat = raster.ravel()
    if len(holes) == 0:
        return np.zeros(0, raster.dtype), np.zeros(0, raster.dtype)
    at = holes % cols
    # Runs of holes along a row share both banks: working per run touches the holes only,
    # where scans over the whole raster cost twice as much.
    first = np.empty(len(holes), bool)
    first[0] = True
    np.not_equal(holes[1:], holes[:-1] + 1, out=first[1:])
    first[1:] |= at[1:] == 0
    starts = np.flatnonzero(first)
    ends = np.r_[starts[1:] - 1, len(holes) - 1]
    run = np.cumsum(first) - 1
    left, right = at[starts] - 1, at[ends] + 1
    bracketed = (left >= 0) & (right < cols)
    lv = np.take(flat, np.where(bracketed, holes[starts] - 1, 0))[run]
    rv = np.take(flat, np.where(bracketed, holes[ends] + 1, 0))[run]
    gap = (right - left).astype(raster.dtype)[run]
    inside = bracketed[run]
    t = np.where(inside, (at - left[run]).astype(raster.dtype) / np.maximum(gap, 1), 0)
    return np.where(inside, lv + t * (rv - lv), np.nan), np.where(inside, gap, np.inf)


def fill_lines(raster: NDArray[np.floating[Any]], *, passes: int = 1) -> NDArray[np.floating[Any]]:
    """Fill NaN cells by straight lines across each gap along the row and the column,
    weighted by the inverse square of the gap length; cells neither line brackets
    (beyond the data) stay NaN.

    A plane is filled exactly, like a TIN across the hole, but without a
    triangulation; short gaps dominate, so a narrow hole follows its near banks.
    A stack of rasters (..., rows, cols) is filled raster by raster. Each further
    pass fills from the cells the last one filled: a tile known only at its corners
    gets its edges in the first pass and its interior in the second.
    """
    for _ in range(passes - 1):
        raster = fill_lines(raster)
    holes, *lines = lines_at_holes(raster)
    if len(holes) == 0:
        return raster
    out = raster.copy()
    out.reshape(-1)[holes] = weighted_lines(*lines)
    return out


def lines_at_holes(raster: NDArray[np.floating[Any]]) -> tuple[NDArray[np.intp], Lines, Lines, Lines, Lines]:
    """The holes of a raster or a stack of rasters (flat indices, ascending) and, at each, the
    straight line along its row and along its column (value, gap length; NaN and inf where the
    line is not bracketed): ``holes, v_row, g_row, v_col, g_col``."""
    holes = np.flatnonzero(np.isnan(raster))
    if len(holes) == 0:
        empty = np.zeros(0, raster.dtype)
        return holes, empty, empty, empty, empty
    rows, cols = raster.shape[-2], raster.shape[-1]
    # A stack is one tall raster for the rows and one wide raster for the columns; only
    # the holes are interpolated.
    flat = raster.reshape(-1, rows, cols)
    v_row, g_row = across_rows(flat.reshape(-1, cols), holes)
    turned = np.swapaxes(flat, -1, -2).reshape(-1, rows)
    # the holes in the turned raster's order, then their answers put back in the holes' order
    turned_holes = np.flatnonzero(np.isnan(turned))
    layer, cell = np.divmod(turned_holes, rows * cols)
    c, r = np.divmod(cell, rows)
    back = layer * (rows * cols) + r * cols + c
    v_turned, g_turned = across_rows(turned, turned_holes)
    v_col, g_col = np.empty(flat.size, v_turned.dtype), np.empty(flat.size, g_turned.dtype)
    v_col[back], g_col[back] = v_turned, g_turned
    return holes, v_row, g_row, v_col[holes], g_col[holes]


def weighted_lines(
    v_row: NDArray[np.floating[Any]],
    g_row: NDArray[np.floating[Any]],
    v_col: NDArray[np.floating[Any]],
    g_col: NDArray[np.floating[Any]],
    *,
    max_gap: float = np.inf,
) -> NDArray[np.floating[Any]]:
    """The row and column lines' values at holes, weighted by the inverse square of their gaps
    (NaN where neither line brackets the hole); a line across a gap of more than ``max_gap``
    cells counts as not bracketing it."""
    # unbracketed lines have gap inf, weight 0
    w_row = 1.0 / np.maximum(g_row, 1.0) ** 2
    w_col = 1.0 / np.maximum(g_col, 1.0) ** 2
    if np.isfinite(max_gap):
        w_row[g_row > max_gap] = 0.0
        w_col[g_col > max_gap] = 0.0
    weight = w_row + w_col
    line = (np.nan_to_num(v_row) * w_row + np.nan_to_num(v_col) * w_col) / np.where(weight > 0, weight, 1.0)
    return np.where(weight > 0, line, np.nan)


# Fill weights by (rows, cols, passes, cells, pattern): they depend on nothing else, and a
# database's tiles share a few hundred patterns, so repeated queries need not work them out again.
_WEIGHTS: dict[tuple[int, int, int, bytes, int], NDArray[np.float64]] = {}
_WEIGHTS_MAX = 100_000
MIN_SHARED = 8  # rasters of one pattern for its weights to be worth working out


def _pattern_weights(
    patterns: NDArray[np.int64], rows: int, cols: int, passes: int, cells: NDArray[np.intp]
) -> NDArray[np.float64]:
    """(P, rows·cols, len(cells)): for each hole pattern (bit k set: cell k known), the weight of
    each known cell in each filled output cell (NaN where the fill does not reach)."""
    n = rows * cols
    if len(patterns) == 0:
        return np.zeros((0, n, len(cells)))
    tag = (rows, cols, passes, cells.tobytes())
    missing = np.array([p for p in patterns.tolist() if (*tag, p) not in _WEIGHTS], np.int64)
    if len(missing):
        known = (missing[:, None] >> np.arange(n)) & 1 == 1
        p_idx, k_idx = np.nonzero(known)
        # One unit raster per known cell of each pattern: 1 there, 0 at the pattern's other known cells.
        units = np.where(known[p_idx], 0.0, np.nan)
        units[np.arange(len(p_idx)), k_idx] = 1.0
        new = np.zeros((len(missing), n, len(cells)))
        new[p_idx, k_idx] = fill_lines(units.reshape(-1, rows, cols), passes=passes).reshape(-1, n)[:, cells]
        if len(_WEIGHTS) + len(missing) > _WEIGHTS_MAX:
            _WEIGHTS.clear()
        _WEIGHTS.update({(*tag, int(p)): w for p, w in zip(missing, new)})
    return np.stack([_WEIGHTS[(*tag, int(p))] for p in patterns])


def _pattern_codes(known: NDArray[np.bool_]) -> NDArray[np.int64]:
    """Each row's pattern of known cells (T, n ≤ 62) as one integer, bit i for cell i: the bits
    packed eight to a byte, the bytes read as one little-endian integer."""
    packed = np.packbits(known, axis=1, bitorder="little")
    out = np.zeros((len(known), 8), np.uint8)
    out[:, : packed.shape[1]] = packed
    return out.view("<i8")[:, 0].astype(np.int64)


def fill_lines_stack(
    stack: NDArray[np.floating[Any]], *, passes: int = 1, cells: NDArray[np.intp] | None = None
) -> NDArray[np.float64]:
    """:func:`fill_lines` of a stack of small rasters (T, rows, cols), at the flat cell
    indices ``cells`` (all cells if None): an array (T, len(cells)).

    For a given pattern of holes the fill is linear in the known values: its weights
    are worked out once per pattern (by filling unit rasters), kept for later calls, and
    applied to every raster of that pattern. Most tiles of a terrain database share a
    few hundred patterns, so this is many times faster than filling each raster.
    """
    count, rows, cols = stack.shape
    n = rows * cols
    flat = stack.reshape(count, n)
    cells = np.arange(n) if cells is None else np.asarray(cells, np.intp)
    if n > 62:  # the pattern no longer fits one integer key
        return np.asarray(fill_lines(stack, passes=passes).reshape(count, n)[:, cells], np.float64)
    known = ~np.isnan(flat)
    code = _pattern_codes(known)
    patterns, inverse, counts = np.unique(code, return_inverse=True, return_counts=True)
    # Weights pay off for a pattern shared by several rasters; the long tail of rare patterns is
    # filled raster by raster. Which way a raster goes is decided by this call's rasters alone,
    # never by the weights earlier calls left: the two ways differ in the last bits, and a result
    # must not depend on what the process did before (a block modelled on any worker).
    shared = counts >= MIN_SHARED
    out = np.full((count, len(cells)), np.nan)
    rare = np.flatnonzero(~shared[inverse])
    if len(rare):
        out[rare] = fill_lines(stack[rare], passes=passes).reshape(len(rare), n)[:, cells]
    use = np.flatnonzero(shared)
    weights = _pattern_weights(patterns[use], rows, cols, passes, cells)
    slot = np.full(len(patterns), -1)
    slot[use] = np.arange(len(use))
    rank = slot[inverse]
    order = np.argsort(rank, kind="stable")
    bounds = np.searchsorted(rank[order], np.arange(len(use) + 1))
    # the shared rasters gathered once, pattern after pattern, so that each product reads and
    # writes one contiguous block (a gather and a scatter per pattern cost more than the products)
    grouped = order[bounds[0] : bounds[-1]]
    values = flat[grouped]
    values[np.isnan(values)] = 0.0
    filled = np.full((len(grouped), len(cells)), np.nan)
    starts = bounds - bounds[0]
    with one_blas_thread():  # one product per pattern: see tdb.threads
        for k, p in enumerate(use):
            if patterns[p]:  # a raster with no known cell stays NaN
                a, b = starts[k], starts[k + 1]
                filled[a:b] = values[a:b] @ weights[k]
    out[grouped] = filled
    return out
