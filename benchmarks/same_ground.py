"""False change on real surveys: each real file split into two random halves, compared.

The two halves of one survey saw the same ground at the same time, so every region a diff
reports between them is false. Each half holds half the returns, so a survey of 1 pulse per m²
is compared as two of 0.5: where the surfaces made between sparse returns miss relief (ditches,
banks, steep ground), each half misses it at other places, and a small region holds a handful of
each half's returns. The diff runs as shipped, and without the relief missed between returns in
the level of detection (:func:`tdb.evidence.missed_relief`), without the least ground returns a
region needs (``tdb.evidence.MIN_RETURNS``), and without either. No setting was chosen here.
    python -m benchmarks.same_ground
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

import numpy as np

import tdb
import tdb.evidence
from benchmarks.common import DATA, save
from ingest.pipeline import ingest
from ingest.readers import read
from queries.changes import detect
from queries.coregister import coregister

FILES = (
    "epochs/TTP_2015.laz",
    "epochs/TTP_2019.laz",
    "las/Topography.laz",
    "las/MixedConifer.laz",
    "las/Megaplot.laz",
    "las/append-bug.laz",
    "isprs/samp11-utm.laz",
    "isprs/samp52-utm.laz",
    "isprs/samp61-utm.laz",
)
# (tdb.evidence.MISSED, tdb.evidence.MIN_RETURNS) of each way the halves are compared
VARIANTS = {
    "shipped": (tdb.evidence.MISSED, tdb.evidence.MIN_RETURNS),
    "without_least_returns": (tdb.evidence.MISSED, 0),
    "without_missed_relief": (0.0, tdb.evidence.MIN_RETURNS),
    "without_either": (0.0, 0),
}


def halves(path: Path, *, seed: int = 1) -> dict[str, Any]:
    """The regions a diff finds between two random halves of the survey at ``path``, per
    :data:`VARIANTS`."""
    cloud = read(path)
    first = np.random.default_rng(seed).random(len(cloud)) < 0.5
    out: dict[str, Any] = {"points": len(cloud)}
    with tempfile.TemporaryDirectory() as tmp:
        db = tdb.open(Path(tmp) / "h.tdb", create=True)
        ingest(cloud.take(first), db, version="a")
        ingest(cloud.take(~first), db, version="b")
        out["tiles"] = len(db.tiles("a", level=2)[0])
        out["pulses_per_m2"] = _density(db)
        for name, (missed, returns) in VARIANTS.items():
            tdb.evidence.MISSED, tdb.evidence.MIN_RETURNS = missed, returns
            found = detect(db, "a", "b", shift=coregister(db, "a", "b"))
            out[name] = {
                "regions": len(found),
                "area_m2": float(sum(f["properties"]["area"] for f in found)),
                "kinds": sorted({f["properties"]["kind"] for f in found}),
            }
        tdb.evidence.MISSED, tdb.evidence.MIN_RETURNS = VARIANTS["shipped"]
    return out


def _density(db: tdb.Database) -> float:
    """A half's pulses per m², the mean over its 2 m tiles (its evidence)."""
    pulses = db.evidence("a").pulses.astype(float)
    return float(np.nanmean(pulses)) if np.isfinite(pulses).any() else float("nan")


def main() -> None:
    runs = {}
    for name in FILES:
        path = DATA / name
        if not path.exists():
            print(name, "absent: skipped")
            continue
        runs[name] = halves(path)
        print(name, runs[name], flush=True)
    print(save("same_ground", {"runs": runs}))


if __name__ == "__main__":
    main()
