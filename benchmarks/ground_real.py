"""Ground filters against the providers' own ground classes on the real files in ``../shared/data``.

The second, independent check of issue 26: no setting of any filter was made on these files.
They are production classifications, not perfect truth, so the figures are agreement, not
error. Scored points: the providers' ground (class 2) against everything they call something
else, leaving out what has no clear answer at ground level: low vegetation (3, which reaches
down into the grass a ground filter keeps), water (9: a DTM takes the water's surface) and the
classes a survey marks unusable (7, 18, and IGN's 65), which no filter here sees.

tdb's filter gets each file's return numbers, as ``tdb ingest`` gives them; the peers take only
coordinates. A filter that runs past five minutes on a file has no figure there (the means are
then over the files it finished, so compare them with care). Coordinates are in metres (``tdb.units.to_metres``).

    python -m benchmarks.ground_real [--methods "tdb auto,pysmrf,CSF"]
"""

from __future__ import annotations

import argparse
import multiprocessing
import queue
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from benchmarks.common import DATA, save
from benchmarks.ground_methods import methods
from ingest.ground import classify_ground
from ingest.ground.evaluate import accuracy
from ingest.readers import read
from tdb.cloud import GROUND, PointCloud
from tdb.units import to_metres

UNSCORED = (3, 7, 9, 18, 65)  # low vegetation, noise, water, IGN artefacts: see the module text
EXCLUDE = (7, 18, 65)  # never shown to a filter
SUMMARY = ("type1", "type2", "total", "kappa")


def files() -> list[Path]:
    return sorted((DATA / "las").glob("*.la[sz]")) + sorted((DATA / "epochs").glob("*.laz"))


def filters() -> dict[str, Callable[[PointCloud], NDArray[np.bool_]]]:
    peers = methods()
    return {
        "tdb auto": lambda c: classify_ground(c, exclude=EXCLUDE),
        "pysmrf": lambda c: peers["pysmrf"](c.xyz),
        "CSF": lambda c: peers["CSF"](c.xyz),
    }


def score(cloud: PointCloud, ground: NDArray[np.bool_]) -> dict[str, float]:
    scored = ~np.isin(cloud.classification, UNSCORED)
    row = accuracy(cloud.classification[scored] == GROUND, ground[scored]).as_dict()
    row["scored"] = int(scored.sum())
    return row


TIME_LIMIT = 300.0  # s per filter and file: CSF's cloth over append-bug.laz's 1 km strip runs for hours


def _filter_in_child(name: str, path: Path, out: Any) -> None:
    cloud = to_metres(read(path))
    shown = np.flatnonzero(~np.isin(cloud.classification, EXCLUDE))
    ground = np.zeros(len(cloud.xyz), bool)
    ground[shown] = filters()[name](cloud.take(shown))
    out.put(ground)


def _ground(name: str, path: Path) -> NDArray[np.bool_] | None:
    """The filter's ground mask of the file, or None where it ran past :data:`TIME_LIMIT`."""
    ctx = multiprocessing.get_context("spawn")
    out = ctx.Queue()
    child = ctx.Process(target=_filter_in_child, args=(name, path, out))
    child.start()
    try:
        return out.get(timeout=TIME_LIMIT)
    except queue.Empty:
        return None
    finally:
        child.kill()
        child.join()


def run(names: list[str]) -> dict[str, dict[str, dict[str, float]]]:
    table: dict[str, dict[str, dict[str, float]]] = {n: {} for n in names}
    for path in files():
        cloud = to_metres(read(path))
        for name in names:
            t0 = time.perf_counter()
            ground = _ground(name, path)
            if ground is None:
                print(f"{name:9s} {path.name:42s} no result in {TIME_LIMIT:.0f} s", flush=True)
                continue
            row = score(cloud, ground)
            row["seconds"] = time.perf_counter() - t0
            table[name][path.name] = row
            print(
                f"{name:9s} {path.name:42s} type I {row['type1']:5.2f} %  type II {row['type2']:5.2f} %"
                f"  kappa {row['kappa']:5.1f}",
                flush=True,
            )
    for name in names:
        rows = list(table[name].values())
        table[name]["mean"] = {k: float(np.mean([r[k] for r in rows])) for k in SUMMARY}
    return table


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--methods", default=",".join(filters()))
    args = parser.parse_args()
    table = run([m.strip() for m in args.methods.split(",")])
    print(save("ground_real", table))


if __name__ == "__main__":
    main()
