"""Peak memory of a process, as the operating system counts it."""

from __future__ import annotations

import sys


def peak_mib(*, children: bool = False) -> float:
    """The largest resident set this process has held, in MiB (with ``children``: the largest
    of its children that have ended and been waited for); 0 where the system does not say."""
    try:
        import resource  # POSIX only
    except ImportError:
        return 0.0
    usage = resource.getrusage(resource.RUSAGE_CHILDREN if children else resource.RUSAGE_SELF)
    # Linux counts ru_maxrss in KiB, macOS in bytes
    return usage.ru_maxrss / (2**20 if sys.platform == "darwin" else 2**10)


def workers_peak_mib(told: float | None) -> float:
    """The largest worker's peak memory (MiB): as the workers ``told`` it (a version's
    ``worker_peak_mib``; they may be no children of this process), else the largest of the child
    processes waited for."""
    return told or peak_mib(children=True)


def physical_bytes() -> int:
    """This machine's physical memory in bytes; 0 where the system does not say."""
    import os

    try:
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, ValueError, OSError):  # no sysconf, or no such name (Windows, odd libcs)
        return 0
