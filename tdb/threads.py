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
