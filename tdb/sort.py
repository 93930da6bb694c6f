"""Points by group (a cell, a tile): their order by group and, within one, by a value; each group's highest
or lowest value."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from tdb.errors import InputError


def by_group(
    group: NDArray[np.integer[Any]],
    key: NDArray[np.floating[Any]],
    *,
    key_order: NDArray[np.intp] | None = None,
) -> NDArray[np.intp]:
    """The order ``np.lexsort((key, group))`` gives: by ``group`` (integers), then by ``key``, of
    equal ones the first first.

    A stable sort by group of the points in key order: one sort of the groups (numpy's timsort,
    quick where groups come in runs), where lexsort merge-sorts twice. ``key_order``:
    ``np.argsort(key, kind="stable")`` where the caller has it (one order by height serves every
    grid's cells: :func:`order_within`).
    """
    order = np.argsort(key, kind="stable") if key_order is None else np.asarray(key_order, np.intp)
    return order[np.argsort(np.asarray(group)[order], kind="stable")]


def order_within(order: NDArray[np.intp], subset: NDArray[np.intp], n: int) -> NDArray[np.intp]:
    """A stable order of ``n`` values (``np.argsort(values, kind="stable")``) restricted to the
    ``subset`` (ascending indices): the stable order of ``values[subset]``, as positions in it.

    Raises
    ------
    InputError
        If ``subset`` is not ascending (ties would then fall in another order).
    """
    subset = np.asarray(subset, np.intp)
    if len(subset) > 1 and (np.diff(subset) <= 0).any():
        raise InputError("subset must be ascending")
    place = np.full(n, -1, np.intp)
    place[subset] = np.arange(len(subset))
    inside = place[order]
    return inside[inside >= 0]


_PASSES = 6  # scatter passes before the rest goes to the ufunc (adversarial orders)


def scatter_max(out: NDArray[Any], index: NDArray[np.integer[Any]], values: NDArray[Any]) -> None:
    """``np.maximum.at(out.reshape(-1), index, values)``, in place, a few times faster.

    Each pass writes the values still above what their cell holds, so a cell ends at its largest
    (whichever value a repeated index keeps, the cell only rises); on typical orders a handful
    of passes over fewer and fewer values is done, and what an adversarial order leaves after
    :data:`_PASSES` goes to the ufunc. Values with NaN go to the ufunc at once, which keeps them.

    Raises
    ------
    InputError
        If ``out`` is not one block of memory (its flat view would be a copy).
    """
    _scatter(out, index, values, np.greater, np.maximum)


def scatter_min(out: NDArray[Any], index: NDArray[np.integer[Any]], values: NDArray[Any]) -> None:
    """``np.minimum.at(out.reshape(-1), index, values)``, in place: see :func:`scatter_max`."""
    _scatter(out, index, values, np.less, np.minimum)


def _scatter(out: NDArray[Any], index: NDArray[Any], values: NDArray[Any], beats: Any, ufunc: Any) -> None:
    flat = out.reshape(-1)
    if not np.shares_memory(flat, out):
        raise InputError("out must be contiguous")
    index, values = np.asarray(index), np.asarray(values)
    if values.dtype.kind == "f" and np.isnan(values).any():
        ufunc.at(flat, index, values)
        return
    keep = beats(values, flat[index])
    index, values = index[keep], values[keep]
    for k in range(_PASSES):
        if len(index) == 0:
            return
        # alternate directions, so that an ascending or a descending run settles in one pass
        step = 1 if k % 2 == 0 else -1
        flat[index[::step]] = values[::step]
        keep = beats(values, flat[index])
        index, values = index[keep], values[keep]
    ufunc.at(flat, index, values)


def highest_per_group(group: NDArray[np.integer[Any]], z: NDArray[np.floating[Any]]) -> NDArray[np.intp]:
    """The index of each group's highest point (of equal ones the first), groups (integers ≥ 0)
    ascending: two passes over the points, where sorting them by group and height costs several
    times more."""
    size = int(group.max()) + 1 if len(group) else 0
    top = np.full(size, -np.inf)
    scatter_max(top, group, z)
    at_top = np.flatnonzero(z == top[group])
    first = np.full(size, len(group), np.intp)
    scatter_min(first, group[at_top], at_top)
    return first[first < len(group)]
