"""Database writes (rows/s) and a 1 km² area query on a ≥100 km² database.

The big database is filled with synthetic rows (categories and kept points on a
10 km × 10 km area at the real 2 m tile density), since ingesting 100 km² of
point clouds is not what this measures.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

import tdb
from benchmarks.common import save

SIDE = 10_000  # m


def main() -> None:
    rng = np.random.default_rng(0)
    with tempfile.TemporaryDirectory() as tmp:
        db = tdb.open(Path(tmp) / "big.tdb", create=True)
        levels = {}
        for level in (2, 4, 8, 16):
            k = np.arange((SIDE // level) ** 2, dtype=np.int64)
            levels[level] = (
                (k % (SIDE // level)) * level + 500_000,
                (k // (SIDE // level)) * level + 5_000_000,
                rng.integers(0, 115, len(k)).astype(np.uint8),
            )
        m = (SIDE // 2) ** 2  # one kept point per 2 m tile corner
        k = np.arange(m, dtype=np.int64)
        points = (
            (k % (SIDE // 2)) * 2.0 + 500_000,
            (k // (SIDE // 2)) * 2.0 + 5_000_000,
            rng.normal(100, 5, m),
            np.ones(m, np.uint8),
        )
        rows = sum(len(v[0]) for v in levels.values()) + m
        t0 = time.perf_counter()
        db.write_version("big", levels=levels, points=points)
        write_s = time.perf_counter() - t0
        times = []
        for _ in range(10):
            x0 = 500_000 + rng.uniform(0, SIDE - 1000)
            y0 = 5_000_000 + rng.uniform(0, SIDE - 1000)
            t0 = time.perf_counter()
            area = db.aoi((x0, y0, x0 + 1000, y0 + 1000), level=2, version="big")
            times.append(time.perf_counter() - t0)
        size = (Path(tmp) / "big.tdb").stat().st_size
        doc = {
            "area_km2": SIDE**2 / 1e6,
            "rows": rows,
            "write_s": write_s,
            "rows_per_s": rows / write_s,
            "file_mib": size / 2**20,
            "aoi_1km2_ms_median": 1000 * float(np.median(times)),
            "aoi_1km2_ms_max": 1000 * float(np.max(times)),
            "aoi_tiles": len(area.code),
            "aoi_points": len(area.x),
        }
    print(doc)
    print(save("db_speed", doc))


if __name__ == "__main__":
    main()
