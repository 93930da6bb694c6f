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

import math
from typing import Any

from benchmarks.ground_cv import run_grid

GRID: dict[str, tuple[Any, ...]] = {
    "unit_steps_from": (4.0, 8.0, math.inf),  # m
    "hills.foot_share": (0.05, 0.1, 0.2),
}


def main() -> None:
    run_grid("windows_cv", GRID, __doc__)


if __name__ == "__main__":
    main()
