"""Process settings tdb makes for its own work."""

from __future__ import annotations

import ctypes.util
import os
import platform
import threading

import numpy as np
import pytest

from tdb.fill import fill_lines_stack
from tdb.threads import keep_freed_memory


@pytest.mark.skipif(platform.system() != "Linux" or not ctypes.util.find_library("c"), reason="glibc's mallopt")
def test_a_cluster_worker_lets_its_allocator_keep_freed_memory() -> None:
    """dask's nanny sets a trim threshold of 64 KiB; a block's worker sets glibc's back to keeping
    freed memory (mallopt answers 1 where it took the setting)."""
    assert keep_freed_memory() is True


def _thread_ticks() -> dict[int, int]:
    """CPU time (clock ticks) of each thread of this process, by thread id."""
    out = {}
    for tid in os.listdir("/proc/self/task"):
        with open(f"/proc/self/task/{tid}/stat") as fh:
            fields = fh.read().rsplit(")", 1)[1].split()
        out[int(tid)] = int(fields[11]) + int(fields[12])  # utime, stime
    return out


@pytest.mark.skipif(platform.system() != "Linux", reason="per-thread CPU times from /proc")
def test_the_rebuilds_products_keep_to_the_calling_thread() -> None:
    """The line rebuild applies one weight product per pattern of holes; on a BLAS pool of
    several threads each would wake the pool, whose threads then spin on the other cores. Held
    to one thread, the pool's threads stay idle however the caller's BLAS is set."""
    from threadpoolctl import threadpool_limits

    rng = np.random.default_rng(0)
    stack = rng.normal(size=(200_000, 5, 5))
    stack[::2, 1, 1] = np.nan  # two patterns, both shared: both go through the products
    main = threading.get_native_id()
    with threadpool_limits(limits=2, user_api="blas"):
        before = _thread_ticks()
        for _ in range(10):
            fill_lines_stack(stack)
        after = _thread_ticks()
    own = after[main] - before[main]
    others = sum(t - before.get(tid, 0) for tid, t in after.items() if tid != main)
    assert own > 0
    assert others <= 0.05 * own + 2, (own, others)
