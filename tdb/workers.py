"""Worker processes on this machine: how many cores there are, and one way to start a pool of them."""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager
from functools import partial
from multiprocessing import get_all_start_methods, get_context
from multiprocessing.context import BaseContext
from typing import TypeVar

from tdb.database import Database
from tdb.database import open as open_database

Job = TypeVar("Job")
Result = TypeVar("Result")


def available_cores() -> int:
    """Cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def one_blas_thread_here() -> None:
    """Hold this process's BLAS and OpenMP pools to one thread (a worker's initializer)."""
    import scipy.linalg  # noqa: F401  (loads scipy's own BLAS, so that the limit reaches it)
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=1)


@contextmanager
def local_pool(workers: int, *, preload: str, initializer: Callable[[], None]) -> Iterator[ProcessPoolExecutor]:
    """A pool of ``workers`` processes, each started ready to run the tasks of module ``preload``.

    A child forked from this process would inherit its threads and locks. The fork server is a
    fresh process that loads ``preload`` once; each worker forks from it ready to work. Where
    there is none (Windows), each worker starts afresh and loads it itself. A failure in the
    ``with`` body cancels the tasks not started.
    """
    context: BaseContext = get_context("spawn")
    if "forkserver" in get_all_start_methods():
        context = get_context("forkserver")
        context.set_forkserver_preload([preload])
    with ProcessPoolExecutor(workers, mp_context=context, initializer=initializer) as pool:
        # One process is spawned per task while none is idle. Each waits for the server to load
        # the modules, so they are asked for from a thread while the caller goes on.
        starter = threading.Thread(target=lambda: [pool.submit(int) for _ in range(workers)], daemon=True)
        starter.start()
        try:
            yield pool
        except BaseException:
            pool.shutdown(wait=False, cancel_futures=True)
            raise
        finally:
            starter.join()


def on_database(
    task: Callable[[Database, Job], Result],
    db: Database,
    jobs: Sequence[Job],
    *,
    workers: int | None,
    preload: str,
) -> Iterator[Result]:
    """``task(db, job)`` for each of ``jobs``, the results in order: in a pool of ``workers``
    processes (None: one per core; :func:`local_pool`, ``preload`` the module of ``task``), each
    of which opens the database itself, where there are several jobs and another process can
    open it (one on disk or on a server); else in this process."""
    n, location = min(workers or available_cores(), len(jobs)), db.location
    if n <= 1 or location is None:
        for job in jobs:
            yield task(db, job)
        return
    with local_pool(n, preload=preload, initializer=one_blas_thread_here) as pool:
        yield from pool.map(partial(_in_worker, task, location), jobs)


_OPENED: dict[str, Database] = {}  # in a worker: the databases it has opened, by location


def _in_worker(task: Callable[[Database, Job], Result], location: str, job: Job) -> Result:
    if location not in _OPENED:
        _OPENED[location] = open_database(location, readonly=True)
    return task(_OPENED[location], job)
