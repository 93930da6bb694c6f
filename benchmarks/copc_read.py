"""Reading and ingesting a part of a large survey: a COPC file read by range against a LAZ scan.

FSite5 (628 k points) is written once as COPC (copclib, ``tests/copc_files.py``); then a box of
``--box`` m in the middle of the site is read from it by range and from the plain LAZ by a scan
of the whole file, and the same box is ingested from each (``tdb ingest --bbox``).

With ``--scene SIZE`` the survey is a synthetic scene of SIZE m at 4 pulses per m² instead
(written as LAZ and as COPC), to see the range read where a whole scan costs what it does.

    python -m benchmarks.copc_read [--box 256] [--scene 2000]
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
from ingest.synth import make_scene, write_scene
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
    parser.add_argument("--scene", type=float, help="a synthetic scene of this many metres instead of FSite5")
    args = parser.parse_args()
    tmpdir = tempfile.TemporaryDirectory()
    source = SOURCE
    if args.scene:
        source = Path(tmpdir.name) / f"scene{args.scene:.0f}.laz"
        write_scene(source, make_scene(seed=1, size=args.scene), density=4.0, seed=1)
    whole = read(source)
    lo, hi = whole.xyz[:, :2].min(axis=0), whole.xyz[:, :2].max(axis=0)
    mid = (lo + hi) / 2
    box = (mid[0] - args.box / 2, mid[1] - args.box / 2, mid[0] + args.box / 2, mid[1] + args.box / 2)
    with tmpdir as tmp:
        copc, write_s = _timed(lambda: write_copc(Path(tmp) / "survey.copc.laz", whole))
        scan, scan_s = _timed(lambda: read_box(source, box))
        ranged, range_s = _timed(lambda: read_box(copc, box))
        runs = {}
        for name, path in (("laz", source), ("copc", copc)):
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
        "file": source.name if not args.scene else f"synthetic scene of {args.scene:.0f} m, 4 pulses/m²",
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
    print(save("copc_read" if not args.scene else "copc_read_scene", doc))


if __name__ == "__main__":
    main()
