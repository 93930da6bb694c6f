"""Three settings of change detection, each chosen by leave-one-seed-out.

``--grid missed`` (saved as ``lod_cv``): a surface interpolated linearly between ground returns
misses κr²/2 of the relief of ground of curvature κ at a node r from the nearest return
(:func:`tdb.evidence.missed_relief`); each tile's LoD grows by it in quadrature
(:func:`queries.tile_change.curved_lod`), here times each factor of the grid (0: no term; 1:
κr²/2, what ships). ``--grid returns`` (saved as ``returns_cv``): the least ground returns each
survey must hold in a region for its change to be claimed (``tdb.evidence.MIN_RETURNS``; 0: no
bound). ``--grid contour`` (saved as ``contour_cv``): the multiple of the LoD a claimed region's
outline is drawn at (``queries.changes.CONTOUR``; 1 ships). All run the synthetic change pairs of
:mod:`benchmarks.changes_synth` at 0.75, 1.5 and 4 pulses/m², score recall and precision by area,
and choose by F1, each seed held out in turn (its three densities are one group,
:func:`benchmarks.common.choose`); the others stay as shipped. The outline moves no region in or
out, only its edge, which a margin of 2 m in the precision does not see: its grid is chosen by the
intersection over union with the true footprints. Seeds 11–14 are never chosen on: they are
scored with the setting chosen on all.
    python -m benchmarks.lod_cv [--grid missed|returns|contour] [--workers 2]
"""

from __future__ import annotations

import argparse
import functools
import tempfile
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path
from typing import Any

import numpy as np

import queries.changes
import tdb
import tdb.evidence
from benchmarks.changes_synth import moved_ground, score
from benchmarks.common import choose, save
from ingest.pipeline import IngestOptions, ingest
from ingest.synth import apply_changes, make_scene, sample
from queries.changes import detect

FACTORS = (0.0, 0.5, 0.75, 1.0, 1.5, 2.0)
CONTOURS = (0.4, 0.5, 0.6, 0.8, 1.0, 1.25, 1.5)
DENSITIES = (0.75, 1.5, 4.0)
CHOSEN_ON = range(1, 7)
NEVER_CHOSEN_ON = range(11, 15)
SIZE = 300.0
# per grid: the tdb.evidence constant it sets, its values by label, and the file it is saved as
GRIDS = {
    "missed": (tdb.evidence, "MISSED", {f"{f:g}": tdb.evidence.MISSED * f for f in FACTORS}, "lod_cv"),
    "returns": (tdb.evidence, "MIN_RETURNS", {f"{k}": float(k) for k in (0, 4, 8, 16, 32)}, "returns_cv"),
    "contour": (queries.changes, "CONTOUR", {f"{t:g}": t for t in CONTOURS}, "contour_cv"),
}

# a grid that moves only the outlines of the regions claimed is judged by how well they fit the
# true footprints (intersection over union), not by recall and precision with a margin
CRITERION = {"contour": "iou"}


def evaluate(case: tuple[int, float], *, grid: str = "missed") -> dict[str, dict[str, float]]:
    """Per setting of ``grid``, recall / precision / F1 by area (and the moved ground's recall) of one pair."""
    module, constant, values, _ = GRIDS[grid]
    shipped = getattr(module, constant)
    seed, density = case
    scene = make_scene(seed=seed, size=SIZE)
    later, changes = apply_changes(scene, seed=seed)
    moved = moved_ground(scene, later, changes)
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        db = tdb.open(Path(tmp) / "c.tdb", create=True)
        options = IngestOptions(exclude=())  # as changes_synth: the filter must find the low outliers
        ingest(sample(scene, density=density, seed=seed), db, version="before", options=options)
        ingest(sample(later, density=density, seed=seed + 1000), db, version="after", options=options)
        for label, value in values.items():
            setattr(module, constant, value)
            s = score(detect(db, "before", "after"), changes, moved=moved)
            r, p = s["recall"], s["precision"]
            f1 = 2 * r * p / (r + p) if r + p > 0 else 0.0
            out[label] = {
                "recall": r,
                "precision": p,
                "f1": f1,
                "iou": s["iou"],
                "recall_moved": s.get("recall_moved"),
            }
    setattr(module, constant, shipped)
    return out


def _name(seed: int, density: float) -> str:
    return f"{seed}@{density:g}"


def summarise(runs: dict[str, dict[str, dict[str, float]]], settings: list[str], by: str = "f1") -> dict[str, Any]:
    """The setting chosen on all chosen-on seeds, each seed's held-out choice and F1, and the
    means per density for every setting, on the chosen-on seeds and on the others."""
    chosen = [_name(s, d) for s in CHOSEN_ON for d in DENSITIES]
    groups = {n: n.split("@")[0] for n in chosen}
    table = {f: {n: runs[n][f][by] for n in chosen} for f in settings}
    tuned, held = choose(table, groups)

    def mean(f: str, d: float, k: str, seeds: range) -> float:
        return float(np.mean([runs[_name(s, d)][f][k] for s in seeds]))

    def means(seeds: range) -> dict[str, dict[str, dict[str, float]]]:
        keys = ("recall", "precision", "f1", "iou")
        return {f: {f"{d:g}": {k: mean(f, d, k, seeds) for k in keys} for d in DENSITIES} for f in settings}

    return {
        "tuned": tuned,
        "by": by,
        "held_out": {g: {"setting": s, by: f} for g, (s, f) in held.items()},
        "held_out_score": float(np.mean([f for _, f in held.values()])),
        "tuned_score": float(np.mean([mean(tuned, d, by, CHOSEN_ON) for d in DENSITIES])),
        "means": means(CHOSEN_ON),
        "never_chosen_on": means(NEVER_CHOSEN_ON),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--grid", choices=sorted(GRIDS), default="missed")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    _, constant, values, result = GRIDS[args.grid]
    cases = [(s, d) for s in (*CHOSEN_ON, *NEVER_CHOSEN_ON) for d in DENSITIES]
    # spawned, not forked: a pool forked from a process whose libraries hold threads can hang
    with ProcessPoolExecutor(args.workers, mp_context=get_context("spawn")) as pool:
        scored = pool.map(functools.partial(evaluate, grid=args.grid), cases)
        runs = {_name(*c): r for c, r in zip(cases, scored, strict=True)}
    summary = summarise(runs, list(values), by=CRITERION.get(args.grid, "f1"))
    print("tuned", summary["tuned"], "held out", summary["by"], round(summary["held_out_score"], 4))
    for f, per in summary["means"].items():
        print(f, {d: {k: round(v, 3) for k, v in m.items()} for d, m in per.items()})
    doc = {"constant": constant, "settings": values, "densities": DENSITIES, "size": SIZE, "runs": runs}
    print(save(result, {**doc, **summary}))


if __name__ == "__main__":
    main()
