"""The median of a square window about each cell of a raster, and weighted quantiles."""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import NDArray

from tdb.errors import InputError

CHUNK_VALUES = 1 << 22  # window values gathered at a time: a band of rows, not the raster's size²
# The 19 compare-exchanges that leave the middle of nine values in place 4 (a sorting network:
# after each pair (a, b), a holds the smaller value and b the larger).
NINE = (
    (1, 2), (4, 5), (7, 8), (0, 1), (3, 4), (6, 7), (1, 2), (4, 5), (7, 8), (0, 3),
    (5, 8), (4, 7), (3, 6), (1, 4), (2, 5), (4, 7), (4, 2), (6, 4), (4, 2),
)  # fmt: skip
BAND_ROWS = 32  # rows of a 3 × 3 median worked at a time: its nine planes stay in the cache


def median_filter(
    raster: NDArray[Any], size: int, *, mode: Literal["constant", "nearest"] = "constant"
) -> NDArray[Any]:
    """:func:`scipy.ndimage.median_filter` of a 2-D raster with an odd square window, beyond
    the edges 0 (``"constant"``) or the edge cell (``"nearest"``): the same values.

    Each band of rows gathers its windows and selects their middle value, which does in one
    call what scipy's filter does a cell at a time (several times faster); a 3 × 3 window goes
    through a sorting network of nine, a few times faster again. Not for rasters holding NaN,
    whose median scipy leaves undefined.

    Raises
    ------
    InputError
        If ``size`` is not an odd positive number or the raster is not 2-D.
    """
    raster = np.asarray(raster)
    if size < 1 or size % 2 == 0 or raster.ndim != 2:
        raise InputError(f"a window median needs a 2-D raster and an odd window, got {raster.ndim}-D and {size}")
    half = size // 2
    padded = np.pad(raster, half, mode="edge" if mode == "nearest" else "constant")
    if size == 3:
        return _median_of_nine(padded)
    rows, cols = raster.shape
    out = np.empty_like(raster)
    middle = size * size // 2
    band = max(1, CHUNK_VALUES // max(1, cols * size * size))
    for r in range(0, rows, band):
        stop = min(rows, r + band)
        windows = sliding_window_view(padded[r : stop + 2 * half], (size, size)).reshape(-1, size * size)
        out[r:stop] = np.partition(windows, middle, axis=1)[:, middle].reshape(stop - r, cols)
    return out


def _median_of_nine(padded: NDArray[Any]) -> NDArray[Any]:
    """The 3 × 3 median of the raster that ``padded`` holds with one cell round it, band by band
    of rows through the :data:`NINE` network: min and max over whole rows, no sorting."""
    rows, cols = padded.shape[0] - 2, padded.shape[1] - 2
    out = np.empty((rows, cols), padded.dtype)
    planes = np.empty((9, min(BAND_ROWS, rows), cols), padded.dtype)
    low = np.empty(planes.shape[1:], padded.dtype)
    for start in range(0, rows, BAND_ROWS):
        n = min(rows, start + BAND_ROWS) - start
        for k in range(9):
            i, j = divmod(k, 3)
            planes[k, :n] = padded[start + i : start + i + n, j : j + cols]
        for a, b in NINE:
            np.minimum(planes[a, :n], planes[b, :n], out=low[:n])
            np.maximum(planes[a, :n], planes[b, :n], out=planes[b, :n])
            planes[a, :n] = low[:n]
        out[start : start + n] = planes[4, :n]
    return out


def weighted_quantile(values: NDArray[np.float64], weights: NDArray[np.float64], q: float) -> float:
    """The smallest of ``values`` at or past the share ``q`` of their summed ``weights``."""
    order = np.argsort(values)
    cum = np.cumsum(weights[order])
    return float(values[order][np.searchsorted(cum, q * cum[-1])])


def weighted_median(values: NDArray[np.float64], weights: NDArray[np.float64]) -> float:
    """:func:`weighted_quantile` at one half."""
    return weighted_quantile(values, weights, 0.5)
