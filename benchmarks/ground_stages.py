"""What each stage of the default ground filter earns, and its limits chosen by leave-one-site-out
(issue 26).

1. Each stage after the refinement passes left out in turn (``AutoParams.skip``), scored on the
   ten ISPRS samples, the real files against their providers' classes and the synthetic scenes,
   as ``benchmarks.ground_cv`` scores its grid. A stage earns its place where leaving it out costs
   some family and helps none; which variant leave-one-site-out picks on ISPRS is printed too.
2. The stages' own limits that touch the ISPRS samples (the hills' cones and least area, the
   opening's slope, the pits' least depth) on a coarse grid around the defaults, chosen by
   leave-one-site-out on the six ISPRS sites, the held-out figure beside the tuned one. The
   earthworks and walls stages change no ISPRS label, so ISPRS cannot choose their limits.

    python -m benchmarks.ground_stages [--workers 2]
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import json
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np

from benchmarks.common import RESULTS, save
from benchmarks.ground_cv import (
    ISPRS_SITES,
    cross_validate,
    cv_rows,
    family,
    isprs_scores,
    params_of,
    samples,
    score_setting,
    site_means,
)
from tdb.options import GroundStage

# Each a physical quantity, on a coarse grid around the default (the default first).
LIMITS: dict[str, tuple[float, ...]] = {
    "hills.slope": (1.0, 0.75, 1.5),  # the gentle cone's slope (rise/run)
    "hills.min_area": (100.0, 50.0, 200.0),  # m²
    "hills.steep_slope": (1.5, 1.25, 2.0),  # the steep cone's slope, for groups with a foot
    "slope": (0.15, 0.1, 0.2),  # the terrain slope the opening tolerates
    "pit_depth": (2.0, 1.5, 3.0),  # m: a pit's least depth
}


def _isprs_scores(setting: dict[str, Any]) -> dict[str, float]:
    return isprs_scores(params_of(setting))


def _skip(stage: GroundStage | None) -> dict[str, float]:
    return score_setting({"skip": frozenset() if stage is None else frozenset({stage})})


def ablation(workers: int) -> dict[str, Any]:
    """Every sample's total error with all stages, and with each stage left out."""
    variants: list[GroundStage | None] = [None, *GroundStage]
    with ProcessPoolExecutor(workers) as pool:
        table = list(pool.map(_skip, variants))
    pairs = samples()
    tuned, held = cross_validate(table, pairs)
    names = ["all stages" if v is None else f"without {v.value}" for v in variants]
    families = _families(pairs)
    return {
        "variants": names,
        "scores": dict(zip(names, table, strict=True)),
        "means": {
            n: {f: float(np.mean([t[s] for s in members])) for f, members in families.items()}
            for n, t in zip(names, table, strict=True)
        },
        "tuned": names[tuned],
        "held_out": {site: names[i] for site, i in held.items() if family(site) == "isprs"},
        "held_out_isprs": _held_mean(table, pairs, held),
    }


def _families(pairs: list[tuple[str, str]]) -> dict[str, list[str]]:
    out: dict[str, list[str]] = {"isprs": [], "real": [], "synthetic": []}
    for sample, site in pairs:
        out[family(site)].append(sample)
    return out


def _held_mean(table: list[dict[str, float]], pairs: list[tuple[str, str]], held: dict[str, int]) -> float:
    return float(np.mean([table[held[site]][sample] for sample, site in pairs if family(site) == "isprs"]))


def limits(workers: int) -> dict[str, Any]:
    """The stages' limits by leave-one-site-out on the ISPRS sites."""
    settings = [dict(zip(LIMITS, v, strict=True)) for v in itertools.product(*LIMITS.values())]
    with ProcessPoolExecutor(workers) as pool:
        table = list(pool.map(_isprs_scores, settings))
    pairs = [(f"samp{s}", f"ISPRS {site}") for s, site in ISPRS_SITES.items()]
    tuned, held = cross_validate(table, pairs)
    default = 0  # every grid lists the default first
    chosen = cv_rows(table, settings, pairs, default=default, tuned=tuned, held=held)
    rows = [dataclasses.asdict(r) for r in chosen]
    return {
        "grid": {k: list(v) for k, v in LIMITS.items()},
        "tuned_setting": settings[tuned],
        "rows": rows,
        "summary": {k: float(np.mean([r[k] for r in rows])) for k in ("default", "tuned", "held_out")},
        "site_means_default": site_means(table[default], pairs),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument(
        "--stages-only",
        action="store_true",
        help="run the ablation alone and keep the limits of the last run (with their own machine and commit)",
    )
    args = parser.parse_args()
    stages = ablation(args.workers)
    for name, means in stages["means"].items():
        print(f"{name:22s}", {k: round(v, 3) for k, v in means.items()}, flush=True)
    print("chosen by leave-one-site-out:", stages["held_out"], "held out", round(stages["held_out_isprs"], 3))
    if args.stages_only:
        last = json.loads((RESULTS / "ground_stages.json").read_text())
        bounds = dict(last["limits"], machine=last["limits"].get("machine", last["machine"]))
    else:
        bounds = limits(args.workers)
        for r in bounds["rows"]:
            print(r, flush=True)
        print("tuned", bounds["tuned_setting"], bounds["summary"])
    print(save("ground_stages", {"stages": stages, "limits": bounds}))


if __name__ == "__main__":
    main()
