"""End-to-end `tdb ingest` on the four ISPRS site clouds, beside the floor and a peer (issue 25).

Per site, each in a fresh process, one after another (nothing else running, the plain
environment): reading the file with laspy (the floor any ingest pays), a whole `tdb ingest` into
a new database (ground, dense model, categories, reduction, evidence, objects, written; three
times, the median kept), and pysmrf's ground filter with PDAL's default parameters and its own
bare-earth DTM (its `classify` returns one at its 1 m cell), then a 0.5 m DEM of its ground
points with voids filled (`create_dem(..., inpaint=True)`), the nearest thing to what tdb
stores. Seconds, points per second, seconds per km² of the survey's extent, and each process's
peak memory.

    python -m benchmarks.ingest_sites [--sites CSite1_red1,CSite2_orig,FSite5_orig,FSite6_orig]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from benchmarks.common import DATA, median_run, run_child, save
from tdb.memory import peak_mib

SITES = ("CSite1_red1", "CSite2_orig", "FSite5_orig", "FSite6_orig")
KINDS = ("read", "ingest", "pysmrf")
DEM_CELL = 0.5  # m: the dense model's post spacing in tdb


def _run(kind: str, src: str, db_path: str) -> None:
    """One run in this process; prints its seconds, the survey's points and extent (from the
    file's header), and peak memory."""
    from ingest.catalog import open_catalog
    from ingest.readers import read

    t0 = time.perf_counter()
    if kind == "ingest":
        import tdb
        from ingest.pipeline import ingest

        ingest(src, tdb.open(db_path, create=True), version="v")
    else:
        cloud = read(src)
        if kind == "pysmrf":
            _pysmrf(cloud.xyz)
    seconds = time.perf_counter() - t0
    header = open_catalog([src])
    x0, y0, x1, y1 = header.bounds
    print(
        json.dumps(
            {
                "seconds": seconds,
                "points": header.points,
                "km2": (x1 - x0) * (y1 - y0) / 1e6,
                "peak_rss_mib": peak_mib(),
            }
        )
    )


def _pysmrf(xyz: Any) -> None:
    import pysmrf

    from benchmarks.peers import smrf

    ground = smrf(xyz)
    g = xyz[ground]
    pysmrf.create_dem(g[:, 0], g[:, 1], g[:, 2], cellsize=DEM_CELL, inpaint=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--sites", default=",".join(SITES))
    parser.add_argument("--run", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.run:
        _run(*args.run)
        return
    out: dict[str, Any] = {}
    for site in args.sites.split(","):
        src = DATA / "isprs" / f"{site}-utm.laz"
        if not src.exists():
            print(f"{src}: absent, skipped", file=sys.stderr)
            continue
        runs = {}
        for kind in KINDS:

            def once(_: int, kind: str = kind, src: Path = src) -> dict[str, Any]:
                with tempfile.TemporaryDirectory() as tmp:
                    return run_child("ingest_sites", kind, str(src), str(Path(tmp) / "s.tdb"))

            # tdb's ingest is the figure the targets read: the median of three; the peer's run once
            r = median_run(once) if kind == "ingest" else once(0)
            r["points_per_s"] = r["points"] / r["seconds"]
            r["s_per_km2"] = r["seconds"] / r["km2"]
            runs[kind] = r
            print(site, kind, r, flush=True)
        out[site] = runs
    print(save("ingest_sites", {"sites": out, "dem_cell_m": DEM_CELL}))


if __name__ == "__main__":
    main()
