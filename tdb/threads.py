"""Thread pools of the numeric libraries, held where tdb's own work needs it.

BLAS threads pay off on large matrix products and cost far more than they save on many small
ones: Qhull's point location makes one tiny LAPACK call per triangle, and the categorisation's
distance products are 4096 × 25 by 25 × 114. Multi-threaded BLAS spins on them, worst on a busy
machine. So that work runs under :func:`one_blas_thread`, whatever the environment says, and a
user's own settings apply everywhere else.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from functools import cache
from typing import Any


@cache
def _controller() -> Any:
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """BLAS held to one thread within the block, restored after it."""
    with _controller().limit(limits=1, user_api="blas"):
        yield


# glibc's mallopt parameters, and what a worker is set to
M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3
MMAP_THRESHOLD = 32 * 2**20  # bytes: arrays larger than this are mapped from the system
TRIM_THRESHOLD = 64 * 2**20  # bytes of freed memory kept before any is returned


@cache
def keep_freed_memory() -> bool:
    """Let this process's allocator (glibc's) keep freed memory for the next arrays; whether it
    was set (False where the C library is not glibc).

    glibc maps every allocation over its threshold (128 KiB at first) afresh from the system and
    returns it when freed. Its own raising of that threshold stops short of tdb's work: an area
    read of a square kilometre makes and drops a dozen arrays of megabytes, and a block of an
    ingest many more, and each fresh page costs a fault. dask.distributed's nanny makes it worse:
    it starts workers with ``MALLOC_TRIM_THRESHOLD_`` at 64 KiB, which turns the raising off.
    Arrays up to 32 MiB are therefore taken from the heap, and up to 64 MiB of freed memory is
    kept for the next ones. Set once per process, when a database is opened and at a worker's
    first block."""
    import ctypes
    import ctypes.util

    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    return bool(mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and bool(mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD))
