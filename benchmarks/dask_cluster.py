"""A blocked ingest on a real dask.distributed cluster beside the local process pool (issue 25).

A ``dask scheduler`` and two ``dask worker`` processes (one thread each, as a user starts them:
``dask scheduler`` and ``dask worker tcp://host:8786``) are started on this machine, on the loopback
address only. The same file is ingested block by block in three ways, each in its own process: with
the local pool of two workers, on the cluster, and with one local worker, each three times (the
median kept: one run's time varies by a tenth on a shared machine). Reported: the seconds of
each, the cluster against the pool (target: within 10 %), and whether the cluster's version is
the pool's, tile for tile at every level and kept point for kept point: for every run of each
kind against the pool's first.

    python -m benchmarks.dask_cluster [--file isprs/FSite5_orig-utm.laz] [--block 512]
"""

from __future__ import annotations

import json
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

import tdb
from benchmarks.common import DATA, file_run_args, median_run, run_child, save
from tdb.tiles import LEVELS

WORKERS = 2
REPEATS = 3  # runs of each kind, every one compared with the pool's first
START_SECONDS = 60  # how long the scheduler and workers may take to come up


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextmanager
def local_cluster(workdir: Path) -> Iterator[str]:
    """A scheduler and :data:`WORKERS` workers as separate processes on 127.0.0.1; their address."""
    dask = shutil.which("dask", path=str(Path(sys.executable).parent)) or "dask"
    address = f"tcp://127.0.0.1:{_free_port()}"
    port = address.rsplit(":", 1)[1]
    logs = [open(workdir / f"dask-{i}.log", "w") for i in range(WORKERS + 1)]
    procs = [
        subprocess.Popen(
            [dask, "scheduler", "--host", "127.0.0.1", "--port", port, "--no-dashboard"],
            stdout=logs[0],
            stderr=subprocess.STDOUT,
        )
    ]
    try:
        for i in range(WORKERS):
            procs.append(
                subprocess.Popen(
                    [dask, "worker", address, "--nthreads", "1", "--no-dashboard", "--host", "127.0.0.1"],
                    stdout=logs[i + 1],
                    stderr=subprocess.STDOUT,
                    cwd=workdir,
                )
            )
        from distributed import Client

        with Client(address, timeout=START_SECONDS) as client:
            client.wait_for_workers(WORKERS, timeout=START_SECONDS)
        yield address
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
        for f in logs:
            f.close()


def _run(kind: str, src: str, db_path: str, block: float, address: str) -> None:
    """One blocked ingest in this process; prints its seconds as JSON."""
    from ingest.blocked import Blocking, ingest_blocked

    db = tdb.open(db_path, create=True)
    blocking = Blocking(
        block=block,
        workers=1 if kind == "one_worker" else WORKERS,
        scheduler=address if kind == "cluster" else None,
    )
    t0 = time.perf_counter()
    ingest_blocked(src, db, version=kind, blocking=blocking)
    print(json.dumps({"seconds": time.perf_counter() - t0}))


def _identical(a: tuple[Any, str], b: tuple[Any, str]) -> dict[str, bool]:
    """Whether versions ``a`` and ``b`` (each a database and a version's name) hold the same
    tiles at every level and the same kept points."""
    out = {}
    for level in LEVELS:
        ta, tb = (db.tiles(v, level=level) for db, v in (a, b))
        out[f"tiles_{level}m"] = all(np.array_equal(x, y) for x, y in zip(ta, tb))
    pa, pb = (db.points(v, level=2) for db, v in (a, b))
    out["kept_points"] = all(np.array_equal(x, y) for x, y in zip(pa, pb))
    return out


def _every_run_identical(tmp: Path, reference: tuple[Any, str], kind: str) -> list[bool]:
    """For each of ``kind``'s runs, whether its version is ``reference``'s in every tile and kept point:
    a run that differs only now and then would pass a check of one run."""
    out = []
    for i in range(REPEATS):
        db = tdb.open(_db_path(tmp, kind, i))
        out.append(all(_identical(reference, (db, kind)).values()))
    return out


def _db_path(tmp: Path, kind: str, i: int) -> str:
    return str(tmp / f"{kind}{i}.tdb")


def main() -> None:
    args = file_run_args(__doc__)
    if args.run:
        kind, src, db_path, block, address = args.run
        _run(kind, src, db_path, float(block), address)
        return
    src = str(DATA / args.file)
    with tempfile.TemporaryDirectory() as name:
        tmp = Path(name)

        def child(kind: str, address: str = "-") -> dict[str, Any]:
            """The median of :data:`REPEATS` runs, each into its own database."""

            def one(i: int) -> dict[str, Any]:
                return run_child("dask_cluster", kind, src, _db_path(tmp, kind, i), str(args.block), address)

            return median_run(one, repeats=REPEATS)

        runs = {"pool": child("pool")}
        with local_cluster(tmp) as address:
            runs["cluster"] = child("cluster", address)
        runs["one_worker"] = child("one_worker")
        db = tdb.open(_db_path(tmp, "pool", 0))
        pool = (db, "pool")
        doc = {
            "file": args.file,
            "points": db.version("pool").stats.points,
            "block_m": args.block,
            "workers": WORKERS,
            "runs": runs,
            "cluster_over_pool": runs["cluster"]["seconds"] / runs["pool"]["seconds"],
            "pool_speedup": runs["one_worker"]["seconds"] / runs["pool"]["seconds"],
            "cluster_speedup": runs["one_worker"]["seconds"] / runs["cluster"]["seconds"],
            "identical": _identical(pool, (tdb.open(_db_path(tmp, "cluster", 0)), "cluster")),
            "identical_runs": {
                kind: _every_run_identical(tmp, pool, kind) for kind in ("pool", "cluster", "one_worker")
            },
        }
    print(doc)
    print(save("dask_cluster", doc))


if __name__ == "__main__":
    main()
