"""The least spread of a ridge (and a ditch), chosen by leave-one-scene-out.

A form stands out of the land beyond its sides too: read twice as far off, its relief is still
most of its own. The strip of land between two ditches (or the path between two banks) stands
out of them alone: read beyond them, its relief is about nothing. ``Filter.min_spread`` bounds the
relief twice as far over the relief from below, as ``max_spread`` bounds it from above.

Each scene is ingested once and asked ``SELECT ridge`` and ``SELECT ditch`` with every bound of
the grid (None: no bound). Scored by length as :mod:`benchmarks.feature_peers` scores (recall of
the ridges, or of ditches where at least 0.3 m deep; precision against every ridge and wall, or
every ditch), F1 per scene. Chosen on the plain seeds 1–10 and the rugged seeds 21–35, each
scene held out in turn (:func:`benchmarks.common.choose`); the rugged seeds 1–5 (the scenes of
``feature_peers``) are never chosen on and are scored with the setting chosen on all.
    python -m benchmarks.spread_cv [--workers 2]
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import tempfile
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager
from multiprocessing import get_context
from pathlib import Path
from typing import Any

import numpy as np
import shapely

import tdb
from benchmarks.common import choose, save
from benchmarks.feature_peers import figures, truths
from ingest.pipeline import IngestOptions, ingest
from ingest.synth import make_scene, sample
from queries.filters import builtin_filters
from queries.match import find

DENSITY = 4.0
Grid = dict[str, tuple[float | None, ...]]  # per filter, the values of the one field put on the grid
GRID: Grid = {"ridge": (None, 0.25, 0.5, 0.75), "ditch": (None, 0.0, 0.25)}
FIELD = "min_spread"
CHOSEN_ON = [("plain", s) for s in range(1, 11)] + [("rugged", s) for s in range(21, 36)]
NEVER_CHOSEN_ON = [("rugged", s) for s in range(1, 6)]


def case_name(kind: str, seed: int) -> str:
    return f"{kind} {seed}"


def _setting(bound: float | None) -> str:
    return "none" if bound is None else f"{bound:g}"


@contextmanager
def scene_database(case: tuple[str, int]) -> Iterator[tuple[dict[str, Any], tdb.Database]]:
    """One scene (``(kind, seed)``) ingested as version ``v`` of a temporary database: the
    truth :func:`benchmarks.feature_peers.truths` scores by, and the database."""
    kind, seed = case
    rugged = kind == "rugged"
    scene = make_scene(seed=seed, size=400.0 if rugged else 300.0, terrain="rugged" if rugged else "plain")
    with tempfile.TemporaryDirectory() as tmp:
        db = tdb.open(Path(tmp) / "s.tdb", create=True)
        ingest(sample(scene, density=DENSITY, seed=seed), db, version="v", options=IngestOptions(exclude=()))
        yield truths(scene), db


def evaluate(
    case: tuple[str, int], *, grid: Grid = GRID, field: str = FIELD
) -> dict[str, dict[str, dict[str, float]]]:
    """Per filter and value of its ``field``, recall / precision / F1 on one scene."""
    known = builtin_filters()
    out: dict[str, dict[str, dict[str, float]]] = {}
    with scene_database(case) as (truth, db):
        for name, bounds in grid.items():
            out[name] = {}
            for bound in bounds:
                change: dict[str, Any] = {field: bound}
                flt = dataclasses.replace(known[name], **change)
                found = shapely.union_all([m.geometry for m in find(db, "v", flt)])
                out[name][_setting(bound)] = figures(truth[name], found)
    return out


def summarise(runs: dict[str, Any], *, grid: Grid = GRID) -> dict[str, Any]:
    """Per filter: the bound chosen on all scenes, each scene's held-out choice and F1, and the
    never-chosen-on scenes scored with the bound chosen on all."""
    doc: dict[str, Any] = {}
    chosen_on = [case_name(*c) for c in CHOSEN_ON]
    for name, bounds in grid.items():
        table = {_setting(b): {n: runs[n][name][_setting(b)]["f1"] for n in chosen_on} for b in bounds}
        tuned, held = choose(table, {n: n for n in chosen_on})
        never = [case_name(*c) for c in NEVER_CHOSEN_ON]

        def mean(setting: str, names: list[str], key: str, name: str = name) -> float:
            return float(np.mean([runs[n][name][setting][key] for n in names]))

        doc[name] = {
            "tuned": tuned,
            "held_out": {n: {"setting": s, "f1": f} for n, (s, f) in held.items()},
            "means": {
                s: {k: mean(s, chosen_on, k) for k in ("recall", "precision", "f1")} for s in map(_setting, bounds)
            },
            "held_out_f1": float(np.mean([f for _, f in held.values()])),
            "never_chosen_on": {
                s: {k: mean(s, never, k) for k in ("recall", "precision", "f1")} for s in map(_setting, bounds)
            },
        }
    return doc


def cross_validate(grid: Grid, field: str, result: str, *, doc: str) -> None:
    """Every scene scored with every value of ``grid`` for the filters' ``field``, the choice by
    leave-one-scene-out, saved as ``result``; ``doc`` the command's help."""
    parser = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    cases = CHOSEN_ON + NEVER_CHOSEN_ON
    scored = functools.partial(evaluate, grid=grid, field=field)
    # spawned, not forked: a pool forked from a process whose libraries hold threads can hang
    with ProcessPoolExecutor(args.workers, mp_context=get_context("spawn")) as pool:
        runs = {case_name(*c): r for c, r in zip(cases, pool.map(scored, cases), strict=True)}
    summary = summarise(runs, grid=grid)
    for name, d in summary.items():
        print(name, "tuned", d["tuned"], "held out F1", round(d["held_out_f1"], 4))
        print("  chosen on", d["means"], "\n  never chosen on", d["never_chosen_on"])
    print(save(result, {"density": DENSITY, "field": field, "grid": grid, "runs": runs, **summary}))


def main() -> None:
    cross_validate(GRID, FIELD, "spread_cv", doc=__doc__ or "")


if __name__ == "__main__":
    main()
