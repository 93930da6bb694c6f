"""A large area ingested block by block with two workers: time and peak memory per process.

The survey is a catalog of synthetic 1 km tiles at 2 pulses/m² (each tile its own scene, so
the terrain does not continue across tile edges: that costs the model nothing it would not meet
at a survey's seams, and this run measures time and memory, not accuracy). The ingest runs in a
child process, as ``tdb ingest DIR --workers 2`` does, and reports its own peak RSS (the parent:
scatter and store) and the largest of its workers'.

    python -m benchmarks.large_area [--tiles 10x5] [--density 2] [--dir /tmp/tdb-large]

Results go to ``large_area.json`` for the defaults, else ``large_area_NXxNY_dDENSITY.json``: a
denser survey shows that the blocks shrink to keep each worker's memory (:mod:`ingest.block_size`).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import tdb
from benchmarks.common import save
from ingest.synth import make_scene, write_scene
from tdb.memory import peak_mib, workers_peak_mib

TILE = 1000.0  # m
ORIGIN = (600_000.0, 5_000_000.0)


def tiles(folder: Path, nx: int, ny: int, density: float) -> list[Path]:
    """The catalog's tiles, written where missing."""
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for i in range(nx):
        for j in range(ny):
            path = folder / f"tile_{i:02d}_{j:02d}.laz"
            if not path.exists():
                origin = (ORIGIN[0] + i * TILE, ORIGIN[1] + j * TILE)
                seed = 1000 + i * ny + j
                write_scene(path, make_scene(seed=seed, size=TILE, origin=origin), density=density, seed=seed)
                print(f"wrote {path.name}", flush=True)
            out.append(path)
    return out


def _run(folder: str, db_path: str, workers: int) -> None:
    """The ingest in this process; prints its seconds and the peak memory as JSON."""
    from ingest.blocked import Blocking, ingest_blocked

    db = tdb.open(db_path, create=True)
    t0 = time.perf_counter()
    v = ingest_blocked(folder, db, version="large", blocking=Blocking(workers=workers))
    seconds = time.perf_counter() - t0
    own = peak_mib()
    children = workers_peak_mib(v.params.get("worker_peak_mib"))
    b = v.stats.bounds or (0.0, 0.0, 0.0, 0.0)
    print(
        json.dumps(
            {
                "seconds": seconds,
                "points": v.stats.points,
                "km2": (b[2] - b[0]) * (b[3] - b[1]) / 1e6,
                "blocks": v.params.get("blocks"),
                "parent_peak_rss_mib": own,
                "worker_peak_rss_mib": children,
            }
        )
    )


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--tiles", default="10x5", help="tiles of 1 km across x down")
    p.add_argument("--density", type=float, default=2.0)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--dir", type=Path, default=Path("/tmp/tdb-large"))
    p.add_argument("--run", nargs=3, help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.run:
        _run(a.run[0], a.run[1], int(a.run[2]))
        return
    nx, ny = (int(v) for v in a.tiles.split("x"))
    folder = a.dir / f"tiles_{nx}x{ny}_{a.density:g}"
    t0 = time.perf_counter()
    tiles(folder, nx, ny, a.density)
    made = time.perf_counter() - t0
    db_path = a.dir / "large.tdb"
    db_path.unlink(missing_ok=True)
    cmd = [sys.executable, "-m", "benchmarks.large_area", "--run", str(folder), str(db_path), str(a.workers)]
    out = subprocess.run(cmd, check=True, capture_output=True)
    run = json.loads(out.stdout.decode().strip().splitlines()[-1])
    doc = {
        "tiles": f"{nx}x{ny}",
        "density": a.density,
        "workers": a.workers,
        "tiles_written_s": made,
        **run,
        "points_per_s": run["points"] / run["seconds"],
        "s_per_km2": run["seconds"] / run["km2"],
        "file_mib": db_path.stat().st_size / 2**20,
    }
    print(json.dumps(doc, indent=1))
    default = (nx, ny, a.density) == (10, 5, 2.0)
    print(save("large_area" if default else f"large_area_{nx}x{ny}_d{a.density:g}", doc))


if __name__ == "__main__":
    main()
