"""Running a ground filter tile by tile, each tile with a buffer of its neighbours' points.

Filters whose every iteration touches the whole cloud (re-triangulation in
Sohn–Dowman) pay for the slowest region on all of it; tiles stop as soon as their
own terrain is done, and memory stays bounded by the tile size.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context

import numpy as np
from numpy.typing import NDArray

from tdb.bbox import column_range
from tdb.workers import one_blas_thread_here


def by_tiles(
    xyz: NDArray[np.float64],
    filter_fn: Callable[[NDArray[np.float64]], NDArray[np.bool_]],
    *,
    target_points: int = 60_000,
    buffer: float = 25.0,
    workers: int = 1,
    progress: Callable[[int, int], None] | None = None,
) -> NDArray[np.bool_]:
    """Ground mask from ``filter_fn`` run on square tiles of about ``target_points`` points.

    Each tile is filtered together with the points within ``buffer`` m around it,
    and only its own points take the result, so edge effects stay in the buffer.
    Clouds that fit one tile are filtered whole. With ``workers`` > 1 the tiles are
    filtered in that many processes (``filter_fn`` must then be a module-level
    function); tiles are independent, so the result is the same. ``progress`` is called
    with (tiles done, tiles) as each tile finishes.
    """
    xy = xyz[:, :2]
    lo, hi = column_range(xy)
    span = np.maximum(hi - lo, 1e-6)
    tiles_wanted = len(xyz) / target_points
    if tiles_wanted <= 1.5:
        whole = filter_fn(xyz)
        if progress:
            progress(1, 1)
        return whole
    side = float(np.sqrt(span[0] * span[1] / tiles_wanted))
    nx, ny = (int(np.ceil(s / side)) for s in span)
    col = np.minimum(((xy[:, 0] - lo[0]) / side).astype(np.intp), nx - 1)
    row = np.minimum(((xy[:, 1] - lo[1]) / side).astype(np.intp), ny - 1)
    jobs = []
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
            if len(near) >= 3:
                jobs.append((near, core[near]))
    out = np.zeros(len(xyz), bool)
    if workers > 1 and len(jobs) > 1:
        # Largest tiles first: a big tile started last would leave the other workers idle.
        jobs.sort(key=lambda job: -len(job[0]))
        # spawn: a forked child would inherit the parent's threads and locks. One BLAS thread
        # per worker: BLAS threads of several processes spinning on the same cores cost
        # far more than they save on a filter's small linear algebra.
        with ProcessPoolExecutor(
            min(workers, len(jobs)), mp_context=get_context("spawn"), initializer=one_blas_thread_here
        ) as pool:
            results = pool.map(filter_fn, [xyz[near] for near, _ in jobs])
            _gather(out, jobs, results, progress)
    else:
        _gather(out, jobs, (filter_fn(xyz[near]) for near, _ in jobs), progress)
    return out


def _gather(
    out: NDArray[np.bool_],
    jobs: list[tuple[NDArray[np.intp], NDArray[np.bool_]]],
    results: Iterable[NDArray[np.bool_]],
    progress: Callable[[int, int], None] | None,
) -> None:
    """Each tile's own points take its result, in tile order, as the results come."""
    for done, ((near, mine), ground) in enumerate(zip(jobs, results), start=1):
        out[near[mine]] = ground[mine]
        if progress:
            progress(done, len(jobs))
