"""Helpers shared by the benchmark scripts: data paths, machine facts, timing, peak memory."""

from __future__ import annotations

import json
import os
import platform
import subprocess
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from tdb.memory import peak_mib

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"
RESULTS = ROOT / "benchmarks" / "results"


def _processor() -> tuple[str, int | None]:
    """The CPU's model name and its physical cores (distinct package and core ids), from /proc/cpuinfo."""
    names, cores, package = [], set(), ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            key, _, value = (part.strip() for part in line.partition(":"))
            if key == "model name":
                names.append(value)
            elif key == "physical id":
                package = value
            elif key == "core id":
                cores.add((package, value))
    except OSError:
        pass
    return (names[0] if names else "unknown"), len(cores) or None


def machine() -> dict[str, Any]:
    try:
        commit = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True
        ).stdout.strip()
    except OSError:
        commit = "unknown"
    cpu, cores = _processor()
    return {
        "cpu": cpu,
        # two logical CPUs on one core's two threads run two workers slower than two cores do
        "cores": cores,
        "logical_cpus": os.cpu_count(),
        "python": platform.python_version(),
        "date": time.strftime("%Y-%m-%d"),
        "commit": commit,
    }


def machine_line(doc: dict[str, Any]) -> str:
    """A results file's machine, date and commit, as docs/benchmarks.md states them."""
    m = doc.get("machine", {})
    cores = f" ({m['cores']} cores, {m['logical_cpus']} logical CPUs)" if m.get("cores") else ""
    return (
        f"{m.get('cpu', '?')}{cores}, Python {m.get('python', '?')}, {m.get('date', '?')}, "
        f"commit {m.get('commit', '?')}"
    )


def file_run_args(description: str | None) -> Any:
    """``--file`` (under ``../shared/data``) and ``--block`` of a blocked-ingest benchmark, and the
    hidden ``--run`` (five words) by which it starts each run in a child (:func:`run_child`)."""
    import argparse

    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--file", default="isprs/FSite5_orig-utm.laz")
    parser.add_argument("--block", type=float, default=512.0)
    parser.add_argument("--run", nargs=5, help=argparse.SUPPRESS)
    return parser.parse_args()


def run_child(module: str, *args: str) -> dict[str, Any]:
    """Run ``python -m benchmarks.MODULE --run ARGS`` in a fresh process (its own peak memory, a
    cold start) and return the JSON it prints last."""
    import sys

    out = subprocess.run(
        [sys.executable, "-m", f"benchmarks.{module}", "--run", *args], check=True, capture_output=True
    )
    return dict(json.loads(out.stdout.decode().strip().splitlines()[-1]))


REPEATS = 3  # runs of a timing that varies from run to run on a shared machine


def median_run(run: Callable[[int], dict[str, Any]], *, repeats: int = REPEATS) -> dict[str, Any]:
    """The run of median ``seconds`` among ``repeats`` calls of ``run(i)`` (i = 0 … repeats − 1;
    each a fresh child, :func:`run_child`), with every run's seconds beside it (``seconds_runs``)
    and the largest peak memory of any (the keys ending in ``rss_mib``)."""
    runs = [run(i) for i in range(repeats)]
    out = dict(sorted(runs, key=lambda r: float(r["seconds"]))[len(runs) // 2])
    for key in out:
        if key.endswith("rss_mib") and all(r.get(key) is not None for r in runs):
            out[key] = max(float(r[key]) for r in runs)
    out["seconds_runs"] = [round(float(r["seconds"]), 3) for r in runs]
    return out


def peak_rss_mib() -> float:
    """Peak resident memory of this process so far (MiB)."""
    return peak_mib()


def save(name: str, doc: dict[str, Any], *, path: Path | None = None) -> Path:
    """Write ``doc`` with the machine's description to ``path`` (default: the results folder's
    ``name``.json, which docs/benchmarks.md is made from)."""
    path = path or RESULTS / f"{name}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({"machine": machine(), **doc}, indent=1, default=float))
    return path


def save_runs(name: str, runs: dict[int, Any], settings: dict[str, Any], mean: Callable[[Any], Any]) -> Path:
    """Save the runs of :func:`synthetic_runs` with ``mean(runs)``, and the hold-out seeds' apart."""
    holdout = settings.pop("holdout_runs")
    doc: dict[str, Any] = {"runs": runs, "mean": mean(runs), **settings}
    if holdout:
        doc["holdout"] = {"runs": holdout, "mean": mean(holdout)}
    print(doc["mean"], doc.get("holdout", {}).get("mean"))
    return save(name, doc)


def synthetic_runs(
    description: str, evaluate: Any, *, extra: Callable[[Any], None] | None = None
) -> tuple[dict[int, Any], dict[str, Any]]:
    """Parse ``--seeds/--size/--density`` (and the options ``extra`` adds to the parser) and run
    ``evaluate(seed, size, density, workdir)`` per seed.

    Returns the runs by seed and the settings to save beside them (with the extra options);
    the runs of the ``--holdout`` seeds are under ``settings["holdout_runs"]``.
    """
    import argparse
    import tempfile

    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--seeds", default="1,2,3,4,5,6,7,8,9,10")
    parser.add_argument(
        "--holdout",
        default="11,12,13,14,15,16,17,18,19,20",
        help="seeds no setting was chosen on, scored apart ('' to skip)",
    )
    parser.add_argument("--size", type=float, default=300)
    parser.add_argument("--density", type=float, default=4)
    if extra:
        extra(parser)
    args = parser.parse_args()
    runs, holdout = {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        for seed in [int(s) for s in args.seeds.split(",")]:
            runs[seed] = evaluate(seed, args.size, args.density, Path(tmp))
            print(seed, runs[seed], flush=True)
        for seed in [int(s) for s in args.holdout.split(",") if s.strip()]:
            holdout[seed] = evaluate(seed, args.size, args.density, Path(tmp))
            print("holdout", seed, holdout[seed], flush=True)
    settings = {k: v for k, v in vars(args).items() if k not in ("seeds", "holdout")}
    settings["holdout_runs"] = holdout
    return runs, settings


def choose(table: dict[str, dict[str, float]], groups: dict[str, str]) -> tuple[str, dict[str, tuple[str, float]]]:
    """The setting best on all groups, and per group the setting best on the others with its score
    there. Each group counts once (the mean of its cases' scores): a scene's three densities are
    one scene, and outweighed the one real forest three to one when each case counted."""

    def mean_over(setting: str, names: list[str]) -> float:
        per_group: dict[str, list[float]] = {}
        for n in names:
            per_group.setdefault(groups[n], []).append(table[setting][n])
        return float(np.nanmean([np.nanmean(v) for v in per_group.values()]))

    names = list(groups)
    settings = list(table)
    tuned = max(settings, key=lambda s: mean_over(s, names))
    held = {}
    for g in sorted(set(groups.values())):
        others = [n for n in names if groups[n] != g]
        mine = [n for n in names if groups[n] == g]
        best = max(settings, key=lambda s: mean_over(s, others))
        held[g] = (best, mean_over(best, mine))
    return tuned, held
