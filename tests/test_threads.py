"""Process settings tdb makes for its own work."""

from __future__ import annotations

import ctypes.util
import platform

import pytest

from tdb.threads import keep_freed_memory


@pytest.mark.skipif(platform.system() != "Linux" or not ctypes.util.find_library("c"), reason="glibc's mallopt")
def test_a_cluster_worker_lets_its_allocator_keep_freed_memory() -> None:
    """dask's nanny sets a trim threshold of 64 KiB; a block's worker sets glibc's back to keeping
    freed memory (mallopt answers 1 where it took the setting)."""
    assert keep_freed_memory() is True
