"""Reading and ingesting a part of a large survey: a COPC file read by range against a LAZ scan.

FSite5 (628 k points) is written once as COPC (copclib, ``tests/copc_files.py``); then a box of
``--box`` m in the middle of the site is read from it by range and from the plain LAZ by a scan
of the whole file, and the same box is ingested from each (``tdb ingest --bbox``).

    python -m benchmarks.copc_read [--box 256]
"""

from __future__ import annotations

import argparse
import functools
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import numpy as np

import tdb
from benchmarks.common import DATA, save
from ingest.blocked import Blocking, ingest_blocked
from ingest.readers import read, read_box
from tests.copc_files import write_copc

T = TypeVar("T")
SOURCE = DATA / "isprs" / "FSite5_orig-utm.laz"


def _timed(fn: Callable[[], T]) -> tuple[T, float]:
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--box", type=float, default=256.0)
    args = parser.parse_args()
    whole = read(SOURCE)
    lo, hi = whole.xyz[:, :2].min(axis=0), whole.xyz[:, :2].max(axis=0)
    mid = (lo + hi) / 2
    box = (mid[0] - args.box / 2, mid[1] - args.box / 2, mid[0] + args.box / 2, mid[1] + args.box / 2)
    with tempfile.TemporaryDirectory() as tmp:
        copc, write_s = _timed(lambda: write_copc(Path(tmp) / "fsite5.copc.laz", whole))
        scan, scan_s = _timed(lambda: read_box(SOURCE, box))
        ranged, range_s = _timed(lambda: read_box(copc, box))
        runs = {}
        for name, path in (("laz", SOURCE), ("copc", copc)):
            db = tdb.open(Path(tmp) / f"{name}.tdb", create=True)
            v, seconds = _timed(
                functools.partial(ingest_blocked, path, db, version="part", blocking=Blocking(region=box))
            )
            runs[name] = {
                "ingest_s": seconds,
                "tiles_2m": v.stats.reduction.tiles.get(2, 0),
                "points": v.stats.points,
            }
    doc = {
        "file": SOURCE.name,
        "file_points": len(whole.xyz),
        "box_m": args.box,
        "box_points": len(ranged.xyz),
        "same_points": bool(
            len(scan.xyz) == len(ranged.xyz) and np.allclose(np.sort(scan.xyz[:, 2]), np.sort(ranged.xyz[:, 2]))
        ),
        "copc_write_s": write_s,
        "laz_scan_read_s": scan_s,
        "copc_range_read_s": range_s,
        "ingest": runs,
    }
    print(doc)
    print(save("copc_read", doc))


if __name__ == "__main__":
    main()
