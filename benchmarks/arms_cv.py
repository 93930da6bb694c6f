"""Where a line's tiles are cut into lines judged alone, chosen by leave-one-scene-out.

Two ditches (or ridges) that meet are one group of touching tiles, and neither its height along
it nor its width is that of one form: :func:`queries.centreline.branches` splits it where three
or more arms run at least an arm's length (:data:`queries.match.ARM`) from a junction, headed
more than ``queries.centreline.ARM_ANGLE`` apart, and each arm is judged alone. A tributary may
join at an acute angle; the rails of a line two tiles wide head a few degrees apart.
``--grid bend``: a line is cut too where it turns by more than ``queries.centreline.BEND``
between arms of an arm's length (none: it is not), where one line may run on into another of
another section (a shallow ditch into a deep one).

Each scene is ingested once and asked ``SELECT ditch`` and ``SELECT ridge`` with every angle of
the grid, scored as :mod:`benchmarks.spread_cv` scores; one angle serves both filters, so the
choice is on the mean of a scene's ditch and ridge F1, each scene held out in turn (the plain
seeds 1–10 and the rugged seeds 21–35; the rugged seeds 1–5 are never chosen on).
    python -m benchmarks.arms_cv [--grid angle|bend] [--workers 2]
"""

from __future__ import annotations

import argparse
import functools
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from typing import Any

import numpy as np
import shapely

import queries.centreline
from benchmarks.common import choose, save
from benchmarks.feature_peers import figures
from benchmarks.spread_cv import CHOSEN_ON, DENSITY, NEVER_CHOSEN_ON, case_name, scene_database
from queries.match import find

ANGLES = (20.0, 30.0, 35.0, 40.0, 45.0, 60.0)  # degrees
# per grid: the queries.centreline constant it sets, its values by label, the file it is saved as
GRIDS: dict[str, tuple[str, dict[str, float | None], str]] = {
    "angle": ("ARM_ANGLE", {f"{a:g}": a for a in ANGLES}, "arms_cv"),
    "bend": ("BEND", {"none": None, "30": 30.0, "45": 45.0, "60": 60.0, "90": 90.0}, "bend_cv"),
}
KINDS = ("ditch", "ridge")


def evaluate(case: tuple[str, int], *, grid: str = "angle") -> dict[str, dict[str, dict[str, float]]]:
    """Per setting of ``grid`` and filter, recall / precision / F1 on one scene."""
    constant, values, _ = GRIDS[grid]
    shipped = getattr(queries.centreline, constant)
    out: dict[str, dict[str, dict[str, float]]] = {}
    with scene_database(case) as (truth, db):
        for label, value in values.items():
            setattr(queries.centreline, constant, value)
            out[label] = {
                name: figures(truth[name], shapely.union_all([m.geometry for m in find(db, "v", name)]))
                for name in KINDS
            }
    setattr(queries.centreline, constant, shipped)
    return out


def summarise(runs: dict[str, Any], settings: list[str]) -> dict[str, Any]:
    """The angle chosen on all scenes, each scene's held-out choice and score, and the means per
    angle and filter on the scenes chosen on and on the others."""
    chosen_on = [case_name(*c) for c in CHOSEN_ON]
    never = [case_name(*c) for c in NEVER_CHOSEN_ON]

    def both(n: str, s: str) -> float:
        return float(np.mean([runs[n][s][k]["f1"] for k in KINDS]))

    table = {s: {n: both(n, s) for n in chosen_on} for s in settings}
    tuned, held = choose(table, {n: n for n in chosen_on})

    def means(names: list[str]) -> dict[str, dict[str, dict[str, float]]]:
        keys = ("recall", "precision", "f1")
        return {
            s: {k: {m: float(np.mean([runs[n][s][k][m] for n in names])) for m in keys} for k in KINDS}
            for s in settings
        }

    return {
        "tuned": tuned,
        "held_out": {n: {"setting": s, "f1": f} for n, (s, f) in held.items()},
        "held_out_f1": float(np.mean([f for _, f in held.values()])),
        "tuned_f1": float(np.mean([table[tuned][n] for n in chosen_on])),
        "means": means(chosen_on),
        "never_chosen_on": means(never),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--grid", choices=sorted(GRIDS), default="angle")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    constant, values, result = GRIDS[args.grid]
    cases = CHOSEN_ON + NEVER_CHOSEN_ON
    # spawned, not forked: a pool forked from a process whose libraries hold threads can hang
    with ProcessPoolExecutor(args.workers, mp_context=get_context("spawn")) as pool:
        scored = pool.map(functools.partial(evaluate, grid=args.grid), cases)
        runs = {case_name(*c): r for c, r in zip(cases, scored, strict=True)}
    summary = summarise(runs, list(values))
    print("tuned", summary["tuned"], "held out F1", round(summary["held_out_f1"], 4))
    for s, per in summary["means"].items():
        print(s, "chosen on", {k: {m: round(v, 3) for m, v in d.items()} for k, d in per.items()})
        never = summary["never_chosen_on"][s]
        print("   never chosen on", {k: {m: round(v, 3) for m, v in d.items()} for k, d in never.items()})
    shipped = getattr(queries.centreline, constant)
    doc = {"density": DENSITY, "constant": constant, "settings": values, "shipped": shipped, "runs": runs}
    print(save(result, {**doc, **summary}))


if __name__ == "__main__":
    main()
