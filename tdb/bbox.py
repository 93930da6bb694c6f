"""Boxes x0, y0, x1, y1 given by users: checked once, clipped to what a version covers; and the
extent of points, column by column."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tdb.errors import InputError

Box = tuple[float, float, float, float]

MAX_COORDINATE = 1e9  # m: no projected coordinate on Earth reaches this


def check_bbox(bbox: Box) -> Box:
    """``bbox`` as floats, or an :class:`InputError` for a box that is not one.

    Raises
    ------
    InputError
        For non-finite numbers, coordinates beyond :data:`MAX_COORDINATE`, or x0 >= x1, y0 >= y1.
    """
    if len(bbox) != 4:
        raise InputError(f"a box needs four numbers x0, y0, x1, y1, got {len(bbox)}")
    x0, y0, x1, y1 = (float(v) for v in bbox)
    if not all(math.isfinite(v) and abs(v) <= MAX_COORDINATE for v in (x0, y0, x1, y1)):
        raise InputError(f"a box needs finite coordinates within ±{MAX_COORDINATE:g} m, got {bbox}")
    if not (x1 > x0 and y1 > y0):
        raise InputError(f"a box needs x0 < x1 and y0 < y1, got {bbox}")
    return (x0, y0, x1, y1)


def clip_bbox(bbox: Box, bounds: Box | None, *, what: str) -> Box:
    """``bbox`` cut to ``bounds`` (``what`` names them in the message); unchanged without bounds.

    Raises
    ------
    InputError
        If the two do not overlap.
    """
    x0, y0, x1, y1 = check_bbox(bbox)
    if bounds is None:
        return (x0, y0, x1, y1)
    cut = (max(x0, bounds[0]), max(y0, bounds[1]), min(x1, bounds[2]), min(y1, bounds[3]))
    if cut[0] >= cut[2] or cut[1] >= cut[3]:
        raise InputError(f"the box {x0:g},{y0:g},{x1:g},{y1:g} does not meet {what}, which covers {bounds}")
    return cut


def column_range(points: NDArray[Any]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The least and the greatest value of each column of ``points`` (n × k).

    Taken column by column: numpy reduces a tall array of a few columns along its first axis an
    order of magnitude slower than each column alone."""
    a = np.asarray(points, dtype=float)
    if a.ndim != 2:
        raise InputError(f"points must be an n × k array, got shape {a.shape}")
    lo = np.array([a[:, k].min() for k in range(a.shape[1])])
    hi = np.array([a[:, k].max() for k in range(a.shape[1])])
    return lo, hi


def box_area(box: Box) -> float:
    """Area of a box (x0, y0, x1, y1), in its units squared; 0 where it is empty."""
    x0, y0, x1, y1 = box
    return max(x1 - x0, 0.0) * max(y1 - y0, 0.0)


def overlaps(a: Box, b: Box) -> bool:
    """Whether boxes ``a`` and ``b`` (x0, y0, x1, y1) share any point, edges included."""
    return a[0] <= b[2] and b[0] <= a[2] and a[1] <= b[3] and b[1] <= a[3]


def boxes_meeting(boxes: NDArray[np.float64], box: Box) -> NDArray[np.intp]:
    """The indices of the rows of ``boxes`` (N, 4: x0, y0, x1, y1) that share a point with
    ``box``, edges included."""
    b = boxes
    return np.flatnonzero((b[:, 0] <= box[2]) & (b[:, 2] >= box[0]) & (b[:, 1] <= box[3]) & (b[:, 3] >= box[1]))


def points_in_box(x: NDArray[Any], y: NDArray[Any], box: Box, *, closed: bool = True) -> NDArray[np.bool_]:
    """Which of the points (``x``, ``y``) lie in ``box``: its east and north edges included where
    ``closed``, else left to the box beyond (a half-open box, so that boxes side by side share no
    point)."""
    x0, y0, x1, y1 = box
    east, north = (x <= x1, y <= y1) if closed else (x < x1, y < y1)
    return np.asarray((x >= x0) & east & (y >= y0) & north)
