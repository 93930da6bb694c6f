"""A feature query over a whole version of many km², by parts and read at once.

The database is built as ``big_db`` builds it: the 1 km² synthetic pair of ``changes_synth``
ingested once (4 points/m²), both versions written N × N times side by side, 1024 m apart.
Then ``SELECT ditch FROM before`` and ``SELECT ridge FROM before`` run over the whole version,
and ``tdb diff before after`` (co-registration, then change detection) over the whole area,
each in a fresh process: by parts (:mod:`queries.parts`, as shipped: a feature query's batches
matched in one worker process per core) and, where asked, by parts in one process alone and read
at once (the parts' lattice limit lifted), with their seconds, peak RSS (of the process, and of
its largest worker) and matches (regions), and whether every way found the same.

    python -m benchmarks.whole_query [--copies 8] [--at-once] [--one-worker] [--queries ditch,ridge,diff]
        [--dir DIR]

Results go to ``whole_query_cCOPIES.json``.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import multiprocessing as mp
import threading
import time
from pathlib import Path
from typing import Any

import tdb
from benchmarks.big_db import build
from benchmarks.changes_synth import km2_pair
from benchmarks.common import peak_rss_mib, save

FILTERS = ("ditch", "ridge", "diff")


def _query(path: str, name: str, at_once: bool, workers: int | None, out: Any) -> None:
    import queries.parts
    from queries.match import find

    if at_once:
        queries.parts.PART_NODES = 10**12  # every box fits: the whole version read at once
    with tdb.open(path, readonly=True) as db, _WorkersPeak() as workers_peak:
        t0 = time.perf_counter()
        matches = find(db, "before", name, workers=workers)
        seconds = time.perf_counter() - t0
    # a measure may be NaN (no relief read), which does not sort: compared as text
    key = sorted((f"{m.measure:.9f}", m.geometry.normalize().wkt) for m in matches)
    out.put(
        {
            "seconds": seconds,
            "matches": len(matches),
            "peak_rss_mib": peak_rss_mib(),
            "worker_peak_rss_mib": workers_peak.mib,
            "key": key,
        }
    )


class _WorkersPeak:
    """The largest resident set any descendant of this process held, sampled every 0.1 s while
    the ``with`` body runs: a query's workers fork from a fork server, not from this process,
    so the system's count of waited-for children does not see them."""

    def __init__(self) -> None:
        self.mib = 0.0
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._watch, daemon=True)

    def _watch(self) -> None:
        import psutil

        me = psutil.Process()
        while not self._done.wait(0.1):
            for child in me.children(recursive=True):
                with contextlib.suppress(psutil.Error):
                    self.mib = max(self.mib, child.memory_info().rss / 2**20)

    def __enter__(self) -> _WorkersPeak:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._done.set()
        self._thread.join()


def _diff(path: str, name: str, at_once: bool, workers: int | None, out: Any) -> None:
    import queries.parts
    from queries.changes import detect
    from queries.coregister import coregister

    if at_once:
        queries.parts.PART_NODES = 10**12
    with tdb.open(path, readonly=True) as db:
        t0 = time.perf_counter()
        shift = coregister(db, "before", "after")
        t1 = time.perf_counter()
        found = detect(db, "before", "after", shift=shift)
        seconds = time.perf_counter() - t1
    props = [f["properties"] for f in found]
    key = sorted((p["kind"], p["tiles"], round(p["area"], 6), p["dz"]) for p in props)
    out.put(
        {
            "seconds": seconds,
            "coregister_s": t1 - t0,
            "matches": len(found),
            "peak_rss_mib": peak_rss_mib(),
            "key": key,
        }
    )


def _build(directory: str, copies: int, out: Any) -> None:
    work = Path(directory)
    km2 = work / "km2.tdb"
    if not km2.exists():
        km2 = km2_pair(work, density=4.0)
    with tdb.open(km2) as source, tdb.open(work / f"whole{copies}.tdb", create=True) as db:
        build(source, db, copies, copies)
        out.put({"bounds": db.version("before").stats.bounds, "rows": db.count("before", table="c2")})


def in_process(target: Any, *args: Any) -> dict[str, Any]:
    """``target(*args, queue)`` in a fresh process (spawned from this small one: Linux counts a
    process's peak memory across the exec from its parent's image), and what it put."""
    ctx = mp.get_context("spawn")
    q = ctx.Queue()
    p = ctx.Process(target=target, args=(*args, q))
    p.start()
    result = q.get()
    p.join()
    return dict(result)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--copies", type=int, default=8)
    p.add_argument("--at-once", action="store_true", help="also read the whole version at once")
    p.add_argument("--one-worker", action="store_true", help="also match the parts in this process alone")
    p.add_argument("--queries", default=",".join(FILTERS), help=f"which of {', '.join(FILTERS)} to run")
    p.add_argument("--dir", type=Path, default=Path("/tmp/tdb-big"), help="where the databases are made and kept")
    a = p.parse_args()
    a.dir.mkdir(parents=True, exist_ok=True)
    built = in_process(_build, str(a.dir), a.copies)  # this process stays small (in_process)
    target, bounds = a.dir / f"whole{a.copies}.tdb", built["bounds"]
    runs = []
    for name in a.queries.split(","):
        run = _diff if name == "diff" else _query
        parted = in_process(run, str(target), name, False, None)
        row: dict[str, Any] = {"filter": name, "parts": {k: v for k, v in parted.items() if k != "key"}}
        keys = [parted["key"]]
        if a.one_worker and run is _query:
            alone = in_process(run, str(target), name, False, 1)
            row["parts_one_worker"] = {k: v for k, v in alone.items() if k != "key"}
            keys.append(alone["key"])
        if a.at_once:
            whole = in_process(run, str(target), name, True, 1)
            row["at_once"] = {k: v for k, v in whole.items() if k != "key"}
            keys.append(whole["key"])
        row["same_matches"] = all(k == keys[0] for k in keys)
        print(json.dumps(row), flush=True)
        runs.append(row)
    doc = {
        "copies": a.copies,
        "area_km2": (bounds[2] - bounds[0]) * (bounds[3] - bounds[1]) / 1e6,
        "rows_2m": built["rows"],
        "runs": runs,
    }
    print(save(f"whole_query_c{a.copies}", doc))


if __name__ == "__main__":
    main()
