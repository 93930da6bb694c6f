"""The widest line a ditch's spread bound lets through, chosen by leave-one-scene-out.

A ditch dug along a valley's floor stands below the valley's sides, which go on rising beyond
the reach its depth is read at: read twice as far off, its depth is the ditch's and the
valley's, and the spread bound (``max_spread``) takes it for a natural valley that widens. A
natural valley fills the usual cross-sections' band; the ditch in it reads as narrow as it is.
``Filter.notch_width``: a line whose cross-sections read it at most this wide passes the spread
bound (None: none does).

Scored and chosen as :mod:`benchmarks.spread_cv` chooses (the same scenes; the rugged seeds 1–5
never chosen on).
    python -m benchmarks.notch_cv [--workers 2]
"""

from __future__ import annotations

from benchmarks.spread_cv import Grid, cross_validate

GRID: Grid = {"ditch": (None, 3.0, 4.0, 5.0)}  # m


def main() -> None:
    cross_validate(GRID, "notch_width", "notch_cv", doc=__doc__ or "")


if __name__ == "__main__":
    main()
