"""Ground filter speed (points/s) and peak memory on the four ISPRS site clouds.

Each (method, cloud) runs in a fresh process so peak memory is its own:
    python -m benchmarks.ground_speed [--methods "tdb auto,pysmrf,CSF"]
    python -m benchmarks.ground_speed --methods "tdb sohn" --save-as ground_speed_sohn
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys

from benchmarks.common import DATA, save

SITES = ["CSite1_red1", "CSite2_orig", "FSite5_orig", "FSite6_orig"]


def one(method: str, site: str) -> dict[str, float]:
    import time

    from benchmarks.common import peak_rss_mib
    from benchmarks.ground_methods import methods
    from ingest.readers import read

    cloud = read(DATA / "isprs" / f"{site}-utm.laz")
    base = peak_rss_mib()
    t0 = time.perf_counter()
    methods()[method](cloud.xyz)
    dt = time.perf_counter() - t0
    from tdb.memory import peak_mib
    from tdb.workers import available_cores

    return {
        "points": len(cloud),
        "seconds": dt,
        "points_per_s": len(cloud) / dt,
        "peak_rss_mib": peak_rss_mib(),
        "rss_after_read_mib": base,
        # Sohn–Dowman filters its tiles in worker processes, one per core: the largest worker's peak
        "worker_peak_rss_mib": peak_mib(children=True),
        "cores": available_cores(),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--methods", default="tdb auto,pysmrf,CSF,tdb contour")
    parser.add_argument(
        "--save-as",
        default="ground_speed",
        help="results name (the slow Sohn–Dowman runs go to ground_speed_sohn)",
    )
    parser.add_argument("--sites", default=",".join(SITES))
    parser.add_argument("--timeout", type=float, default=1800, help="seconds per run before it is stopped")
    parser.add_argument("--one", nargs=2, metavar=("METHOD", "SITE"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        print(json.dumps(one(*args.one)))
        return
    table: dict[str, dict[str, dict[str, float]]] = {}
    for method in [m.strip() for m in args.methods.split(",")]:
        table[method] = {}
        for site in [s.strip() for s in args.sites.split(",")]:
            try:
                out = subprocess.run(
                    [sys.executable, "-m", "benchmarks.ground_speed", "--one", method, site],
                    capture_output=True,
                    text=True,
                    timeout=args.timeout,
                )
            except subprocess.TimeoutExpired:
                table[method][site] = {"error": f"stopped after {args.timeout:.0f} s"}
                print(method, site, table[method][site], flush=True)
                continue
            if out.returncode != 0:
                table[method][site] = {"error": out.stderr.strip().splitlines()[-1] if out.stderr else "failed"}
            else:
                table[method][site] = json.loads(out.stdout.strip().splitlines()[-1])
            print(method, site, table[method][site], flush=True)
    print(save(args.save_as, {"table": table}))


if __name__ == "__main__":
    main()
