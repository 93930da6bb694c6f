"""Co-registration on synthetic survey pairs re-surveyed with a known offset.

Each seed makes a scene and its re-survey with known changes (as ``changes_synth``), and the
re-survey once more with an offset drawn for the seed: dx, dy uniform in ±1 m, dz in ±0.5 m.
Reported per seed: the offset found by ``auto`` against the true one; change recall and
precision by area after co-registration, beside the same pair without the offset; whether the
changes are typed as without the offset; whether ``auto`` applied anything to the pair without
an offset; and the seconds co-registration took per km².
    python -m benchmarks.coregister_synth [--seeds 1,...,10] [--holdout 11,...,20] [--size 300] [--density 4]
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path
from typing import Any

import numpy as np

import tdb
from benchmarks.changes_synth import score
from benchmarks.common import save_runs, synthetic_runs
from ingest.pipeline import IngestOptions, ingest
from ingest.synth import apply_changes, make_scene, sample
from queries.changes import detect
from queries.coregister import coregister

ALL = IngestOptions(exclude=())  # the scenes' low outliers stay in, as in an unclassified survey


def offset_for(seed: int) -> np.ndarray:
    rng = np.random.default_rng(1000 + seed)
    return np.array([rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-0.5, 0.5)])


def offset_pair(seed: int, size: float, density: float, path: Path) -> tuple[tdb.Database, np.ndarray, list[Any]]:
    """A database at ``path`` holding the seed's scene ("before"), its re-survey with changes
    ("after") and the same re-survey offset by :func:`offset_for` ("moved"); the offset and the
    true changes."""
    scene = make_scene(seed=seed, size=size)
    later, changes = apply_changes(scene, seed=seed)
    resurvey = sample(later, density=density, seed=seed + 1000)
    offset = offset_for(seed)
    db = tdb.open(path, create=True)
    ingest(sample(scene, density=density, seed=seed), db, version="before", options=ALL)
    ingest(resurvey, db, version="after", options=ALL)
    ingest(dataclasses.replace(resurvey, xyz=resurvey.xyz + offset), db, version="moved", options=ALL)
    return db, offset, changes


def evaluate(seed: int, size: float, density: float, workdir: Path) -> dict[str, Any]:
    db, offset, changes = offset_pair(seed, size, density, workdir / f"o{seed}.tdb")
    plain = coregister(db, "before", "after")
    t0 = time.perf_counter()
    shift = coregister(db, "before", "moved")
    seconds = time.perf_counter() - t0
    km2 = size * size / 1e6
    without = score(detect(db, "before", "after", shift=plain), changes)
    aligned = score(detect(db, "before", "moved", shift=shift), changes)
    return {
        "offset": offset.tolist(),
        "found": [shift.dx, shift.dy, shift.dz],
        "horizontal_error_m": float(np.hypot(shift.dx - offset[0], shift.dy - offset[1])),
        "vertical_error_m": float(abs(shift.dz - offset[2])),
        "applied": [shift.horizontal, shift.vertical],
        "no_offset_applied": plain.applied,
        "recall": aligned["recall"],
        "precision": aligned["precision"],
        "recall_without_offset": without["recall"],
        "precision_without_offset": without["precision"],
        "typed_as_without_offset": sum(
            aligned["typed"].get(k, {}).get("got") == t["got"] for k, t in without["typed"].items()
        ),
        "changes": len(without["typed"]),
        "coregister_s_per_km2": seconds / km2,
    }


def _mean(runs: dict[int, Any]) -> dict[str, Any]:
    r = list(runs.values())
    return {
        "horizontal_error_m_max": float(max(x["horizontal_error_m"] for x in r)),
        "vertical_error_m_max": float(max(x["vertical_error_m"] for x in r)),
        "recall": float(np.mean([x["recall"] for x in r])),
        "precision": float(np.mean([x["precision"] for x in r])),
        "recall_without_offset": float(np.mean([x["recall_without_offset"] for x in r])),
        "precision_without_offset": float(np.mean([x["precision_without_offset"] for x in r])),
        "typed_as_without_offset": sum(x["typed_as_without_offset"] for x in r),
        "changes": sum(x["changes"] for x in r),
        "no_offset_applied": sum(bool(x["no_offset_applied"]) for x in r),
        "coregister_s_per_km2": float(np.median([x["coregister_s_per_km2"] for x in r])),
    }


def main() -> None:
    runs, settings = synthetic_runs(__doc__, evaluate)
    print(save_runs("coregister_synth", runs, settings, _mean))


if __name__ == "__main__":
    main()
