"""The default ground filter's opening windows and the hills' foot, by leave-one-site-out (issue 26).

How the openings' windows grow (``AutoParams.unit_steps_from``: from this radius on, one cell at
a time; 4 m is SMRF's schedule, every radius; none, doubling to the largest window) and how much
of a steep hill's rim must meet the ground beside it (``HillShape.foot_share``). The two are
chosen together: a finer schedule leaves a broad embankment's crest to the passes and hands the
hills stage smaller groups with less of their rim at the ground's level. Scored and chosen as
``benchmarks.ground_cv`` scores and chooses its grid, on every family.

    python -m benchmarks.windows_cv [--workers 2] [--table earlier.json]
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from benchmarks.common import save
from benchmarks.ground_cv import choose

GRID: dict[str, tuple[Any, ...]] = {
    "unit_steps_from": (4.0, 8.0, math.inf),  # m
    "hills.foot_share": (0.05, 0.1, 0.2),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--table", type=Path, help="reuse the scores of an earlier run's JSON (same grid)")
    args = parser.parse_args()
    print(save("windows_cv", choose(GRID, workers=args.workers, table_from=args.table)))


if __name__ == "__main__":
    main()
