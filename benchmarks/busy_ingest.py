"""``tdb ingest`` of the demo scene while another process keeps one core busy.

The product must not depend on thread settings a user does not make: the measured runs are the
plain command in the plain environment. The reference runs hold BLAS to one thread through the
environment, the setting that once made the difference (issue 24's target is plain ≤ 1.3 ×
reference). Each run is its own process; the median of three of each is reported.

python -m benchmarks.busy_ingest
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.common import save

RUNS = 3
SPIN = "while True: pass"


def _ingest_seconds(scene: Path, db: Path, env: dict[str, str]) -> float:
    for suffix in ("", "-wal", "-shm"):
        Path(f"{db}{suffix}").unlink(missing_ok=True)
    t0 = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "tdb.cli", "ingest", str(scene), "--db", str(db), "--version", "demo"],
        check=True,
        env=env,
        capture_output=True,
    )
    return time.perf_counter() - t0


def main() -> None:
    from ingest.synth import make_scene, write_scene

    with tempfile.TemporaryDirectory() as tmp:
        scene = Path(tmp) / "demo.laz"
        points = write_scene(scene, make_scene(seed=7, size=250.0), density=3.0, seed=7)
        db = Path(tmp) / "demo.tdb"
        plain = dict(os.environ)
        one_thread = {**plain, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
        busy = subprocess.Popen([sys.executable, "-c", SPIN])
        try:
            times: dict[str, list[float]] = {"plain": [], "one_blas_thread": []}
            for _ in range(RUNS):  # interleaved, so that drift in the machine's load hits both
                times["plain"].append(_ingest_seconds(scene, db, plain))
                times["one_blas_thread"].append(_ingest_seconds(scene, db, one_thread))
        finally:
            busy.kill()
    median = {k: statistics.median(v) for k, v in times.items()}
    ratio = median["plain"] / median["one_blas_thread"]
    print(f"{points:,} points; plain {median['plain']:.2f} s, one BLAS thread {median['one_blas_thread']:.2f} s")
    print(f"ratio {ratio:.2f} (target ≤ 1.3)")
    save("busy_ingest", {"points": points, "runs": times, "median_s": median, "ratio": ratio, "target": 1.3})


if __name__ == "__main__":
    main()
