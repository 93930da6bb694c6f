"""Running a ground filter tile by tile, each tile with a buffer of its neighbours' points.

Filters whose every iteration touches the whole cloud (re-triangulation in
Sohn–Dowman) pay for the slowest region on all of it; tiles stop as soon as their
own terrain is done, and memory stays bounded by the tile size.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray


def by_tiles(
    xyz: NDArray[np.float64],
    filter_fn: Callable[[NDArray[np.float64]], NDArray[np.bool_]],
    *,
    target_points: int = 60_000,
    buffer: float = 25.0,
) -> NDArray[np.bool_]:
    """Ground mask from ``filter_fn`` run on square tiles of about ``target_points`` points.

    Each tile is filtered together with the points within ``buffer`` m around it,
    and only its own points take the result, so edge effects stay in the buffer.
    Clouds that fit one tile are filtered whole.
    """
    xy = xyz[:, :2]
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    span = np.maximum(hi - lo, 1e-6)
    tiles_wanted = len(xyz) / target_points
    if tiles_wanted <= 1.5:
        return filter_fn(xyz)
    side = float(np.sqrt(span[0] * span[1] / tiles_wanted))
    nx, ny = (int(np.ceil(s / side)) for s in span)
    col = np.minimum(((xy[:, 0] - lo[0]) / side).astype(np.intp), nx - 1)
    row = np.minimum(((xy[:, 1] - lo[1]) / side).astype(np.intp), ny - 1)
    out = np.zeros(len(xyz), bool)
    for r in range(ny):
        for c in range(nx):
            core = (row == r) & (col == c)
            if not core.any():
                continue
            x0, y0 = lo[0] + c * side - buffer, lo[1] + r * side - buffer
            near = np.flatnonzero(
                (xy[:, 0] >= x0)
                & (xy[:, 0] <= x0 + side + 2 * buffer)
                & (xy[:, 1] >= y0)
                & (xy[:, 1] <= y0 + side + 2 * buffer)
            )
            if len(near) < 3:
                continue
            ground = filter_fn(xyz[near])
            mine = core[near]
            out[near[mine]] = ground[mine]
    return out
