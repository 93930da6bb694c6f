"""The default ground filter's settings by leave-one-site-out cross-validation (issue 26).

Every candidate setting is scored on every sample. The setting is chosen on the six ISPRS
sites, whose reference is exact (samples of one site share its terrain and its survey, so they
are held out together): each ISPRS site is scored with the setting that does best on the other
five, and that held-out figure is printed beside the figure of the setting chosen on all six.
The gap between the two measures how much the choice is fitted. A site weighs as much as any
other: its score is the mean total error of its samples.

Two checks that no choice is made on, scored with the setting chosen on all six: the real files
of ``../shared/data`` against their providers' ground classes (``benchmarks.ground_real``; the
two TTP surveys are one park), and synthetic scenes (``tdb synth``: terrain with mounds,
ditches, walls and embankments under trees and buildings, every point's class known). Their
figures are printed per setting too: a setting that helps ISPRS and hurts them is suspect.

    python -m benchmarks.ground_cv [--workers 2] [--table earlier.json]
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import itertools
import json
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import DATA, save
from benchmarks.ground_real import EXCLUDE, files, score
from ingest.ground.auto import AutoParams, auto_ground
from ingest.ground.evaluate import accuracy
from ingest.readers import read
from ingest.synth import make_scene
from ingest.synth import sample as survey_of
from tdb.cloud import GROUND, PointCloud
from tdb.units import to_metres

ISPRS_SITES = {
    "11": "1",
    "21": "2",
    "22": "2",
    "24": "2",
    "31": "3",
    "41": "4",
    "51": "5",
    "52": "5",
    "54": "5",
    "61": "6",
}

SYNTHETIC = (1, 2, 3, 4)  # scene seeds
SYNTHETIC_SIZE, SYNTHETIC_DENSITY = 300.0, 4.0  # m, pulses per m², as benchmarks.changes_synth

# The settings compared: each a physical quantity, each on a coarse grid around the default.
GRID: dict[str, tuple[Any, ...]] = {
    "flat_rejoin": (False, True),
    "threshold": (0.1, 0.2, 0.3),
    "threshold_spacings": (0.0, 0.1, 0.2, 0.3),
    "slope_scale": (1.0, 1.25, 1.5),
}


@dataclasses.dataclass(frozen=True)
class CvRow:
    """One sample's total error (%) with the default, the setting tuned on all sites, and the
    setting chosen without its own site."""

    sample: str
    site: str
    default: float
    tuned: float
    held_out: float
    held_out_setting: dict[str, Any]


def samples() -> list[tuple[str, str]]:
    """(sample, site) pairs: the ISPRS samples, then the real files."""
    out = [(f"samp{s}", f"ISPRS {site}") for s, site in ISPRS_SITES.items()]
    for path in files():
        out.append((path.name, "TTP" if path.name.startswith("TTP_") else path.stem))
    out += [(f"synthetic {seed}", f"synthetic {seed}") for seed in SYNTHETIC]
    return out


@functools.cache
def isprs_sample(s: str) -> PointCloud:
    """One ISPRS sample, read once per process."""
    return read(DATA / "isprs" / f"samp{s}-utm.laz")


def isprs_scores(params: AutoParams) -> dict[str, float]:
    """Total error (%) of the default filter with ``params`` on each ISPRS sample."""
    out = {}
    for s in ISPRS_SITES:
        cloud = isprs_sample(s)
        out[f"samp{s}"] = accuracy(cloud.classification == 2, auto_ground(cloud.xyz, params=params)).total
    return out


def family(site: str) -> str:
    """Which family a site belongs to: the ISPRS sites chosen on, or one of the two checks."""
    return "isprs" if site.startswith("ISPRS") else "synthetic" if site.startswith("synthetic") else "real"


HILLS = "hills."  # a setting's prefix that names a field of the hills' shape


def params_of(setting: dict[str, Any]) -> AutoParams:
    """The default parameters with ``setting`` applied; ``hills.x`` names a field of the hills' shape."""
    flat = {k: v for k, v in setting.items() if not k.startswith(HILLS)}
    hills = {k.removeprefix(HILLS): v for k, v in setting.items() if k.startswith(HILLS)}
    p = dataclasses.replace(AutoParams(), **flat)
    return dataclasses.replace(p, hills=dataclasses.replace(p.hills, **hills)) if hills else p


def default_setting(grid: dict[str, tuple[Any, ...]]) -> dict[str, Any]:
    """The shipped values of ``grid``'s settings (:func:`params_of`'s names)."""
    p = AutoParams()
    return {k: getattr(p.hills, k.removeprefix(HILLS)) if k.startswith(HILLS) else getattr(p, k) for k in grid}


def score_setting(setting: dict[str, Any]) -> dict[str, float]:
    """Total error (%) of the default filter with ``setting`` (:func:`params_of`) on every sample."""
    params = params_of(setting)
    out = isprs_scores(params)
    for path in files():
        cloud = to_metres(read(path))
        shown = np.flatnonzero(~np.isin(cloud.classification, EXCLUDE))
        kept = cloud.take(shown)
        ground = np.zeros(len(cloud.xyz), bool)
        ground[shown] = auto_ground(kept.xyz, params=params, returns=(kept.return_number, kept.number_of_returns))
        out[path.name] = score(cloud, ground)["total"]
    for seed in SYNTHETIC:
        cloud = survey_of(make_scene(seed=seed, size=SYNTHETIC_SIZE), density=SYNTHETIC_DENSITY, seed=seed)
        ground = auto_ground(cloud.xyz, params=params, returns=(cloud.return_number, cloud.number_of_returns))
        out[f"synthetic {seed}"] = accuracy(cloud.classification == GROUND, ground).total
    return out


def site_means(scores: dict[str, float], pairs: list[tuple[str, str]]) -> dict[str, float]:
    sites: dict[str, list[float]] = {}
    for sample, site in pairs:
        sites.setdefault(site, []).append(scores[sample])
    return {site: float(np.mean(v)) for site, v in sites.items()}


def cross_validate(table: list[dict[str, float]], pairs: list[tuple[str, str]]) -> tuple[int, dict[str, int]]:
    """The setting best on all ISPRS sites, and per site the setting best on the other ISPRS
    sites (for the checks, never chosen on: the setting best on all ISPRS sites)."""
    means = [site_means(t, pairs) for t in table]
    sites = list(means[0])
    chosen_on = [s for s in sites if s.startswith("ISPRS")]

    def best(use: list[str]) -> int:
        return int(np.argmin([np.mean([m[s] for s in use]) for m in means]))

    tuned = best(chosen_on)
    return tuned, {
        site: best([s for s in chosen_on if s != site]) if site in chosen_on else tuned for site in sites
    }


def cv_rows(
    table: list[dict[str, float]],
    settings: list[dict[str, Any]],
    pairs: list[tuple[str, str]],
    *,
    default: int,
    tuned: int,
    held: dict[str, int],
) -> list[CvRow]:
    """Per sample, the scores of the default, the tuned setting and the one chosen without its
    site (:func:`cross_validate`'s choices, indices into ``settings`` and ``table``)."""
    return [
        CvRow(
            sample=sample,
            site=site,
            default=table[default][sample],
            tuned=table[tuned][sample],
            held_out=table[held[site]][sample],
            held_out_setting=settings[held[site]],
        )
        for sample, site in pairs
    ]


def choose(grid: dict[str, tuple[Any, ...]], *, workers: int, table_from: Path | None = None) -> dict[str, Any]:
    """Every setting of ``grid`` scored on every sample (or the scores of an earlier run's JSON,
    ``table_from``, on the same grid), chosen by leave-one-site-out on ISPRS: the document saved."""
    settings = [dict(zip(grid, values)) for values in itertools.product(*grid.values())]
    scored_at = None
    if table_from:
        # the scores of an earlier run (they do not depend on the defaults): choose again only
        earlier = json.loads(table_from.read_text())
        if [t["setting"] for t in earlier["table"]] != settings:
            raise SystemExit(f"{table_from}: scored on another grid")
        table = [t["scores"] for t in earlier["table"]]
        scored_at = earlier.get("scored_at") or earlier.get("machine")
    else:
        with ProcessPoolExecutor(workers) as pool:
            table = list(pool.map(score_setting, settings))
    pairs = samples()
    tuned, held = cross_validate(table, pairs)
    default = settings.index(default_setting(grid))
    rows = cv_rows(table, settings, pairs, default=default, tuned=tuned, held=held)
    for r in rows:
        print(
            f"{r.sample:42s} {r.site:12s} default {r.default:6.2f}  tuned {r.tuned:6.2f}"
            f"  held out {r.held_out:6.2f}  {r.held_out_setting}",
            flush=True,
        )
    families = {f"{f}_mean": [r for r in rows if family(r.site) == f] for f in ("isprs", "synthetic", "real")}
    summary = {
        key: {name: float(np.mean([getattr(r, key) for r in f])) for name, f in families.items()}
        for key in ("default", "tuned", "held_out")
    }
    print("tuned setting", settings[tuned], "default", settings[default])
    print(summary)
    doc = {
        "grid": {k: list(v) for k, v in grid.items()},
        "tuned_setting": settings[tuned],
        "default_setting": settings[default],
        "rows": [dataclasses.asdict(r) for r in rows],
        "summary": summary,
        "table": [{"setting": s, "scores": t} for s, t in zip(settings, table)],
    }
    if scored_at:
        doc["scored_at"] = scored_at
    return doc


def run_grid(name: str, grid: dict[str, tuple[Any, ...]], description: str | None) -> None:
    """The command line of a cross-validated grid: :func:`choose` it, save it as ``name``."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--table", type=Path, help="reuse the scores of an earlier run's JSON (same grid)")
    args = parser.parse_args()
    print(save(name, choose(grid, workers=args.workers, table_from=args.table)))


def main() -> None:
    run_grid("ground_cv", GRID, __doc__)


if __name__ == "__main__":
    main()
