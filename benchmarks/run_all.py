"""Run every benchmark, each in its own process (a fair, cold start), then write docs/benchmarks.md.

python -m benchmarks.run_all   (or `make bench`; the peers come from the ``bench`` extra)
"""

from __future__ import annotations

import subprocess
import sys

# Each module's own defaults; the slow ones (Sohn–Dowman's site clouds, the 100 km² database)
# are in the list all the same: the table is only honest when every row comes from one commit.
MODULES = (
    "busy_ingest",  # first: it wants the machine to itself but for the busy process it starts
    "categorise_speed",
    "db_speed",
    "ground_isprs",
    "ground_real",
    "ground_cv",
    "ground_speed",
    "reduction",
    "features",
    "feature_peers",  # GRASS's geomorphons where `grass` is installed (Debian grass-core)
    "changes_synth",
    "epochs",
    "coregister_synth",
    "coregister_peers",
    "copc_read",
    "dask_cluster",
    "buffered_tiles",
    "objects_cv",
    "objects_speed",
)


def main() -> None:
    for name in MODULES:
        print(f"== benchmarks.{name}", flush=True)
        subprocess.run([sys.executable, "-m", f"benchmarks.{name}"], check=True)
    subprocess.run([sys.executable, "-m", "benchmarks.report"], check=True)


if __name__ == "__main__":
    main()
