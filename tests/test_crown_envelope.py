"""Crown boundaries moved to where the crowns' paraboloids cross (:mod:`ingest.objects.crown_envelope`)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ingest.objects.crown_envelope import crossed_boundaries
from ingest.objects.crowns import fit_paraboloids

CELL = 0.7


def _dome(x: np.ndarray, y: np.ndarray, cx: float, cy: float, h: float, r: float) -> np.ndarray:
    return h - 0.6 * h * ((x - cx) ** 2 + (y - cy) ** 2) / r**2


def _tall_and_low(shift: int) -> tuple[np.ndarray, np.ndarray, int]:
    """A canopy of two domes on cells of ``CELL`` m, a tall crown at x = 8 m and a low one at
    x = 15 m; the labels split them ``shift`` cells to the low crown's side of where the
    domes cross (as a climb on a smoothed canopy does), and the column of the crossing."""
    rows, cols = np.mgrid[0:24, 0:34]
    x, y = (cols + 0.5) * CELL, (rows + 0.5) * CELL
    tall, low = _dome(x, y, 8, 8, 22, 5), _dome(x, y, 15, 8, 12, 4)
    canopy = np.maximum(tall, low)
    crown = canopy > 4.0
    # where the two domes cross on the row through both tops
    crossing = int(np.argmax((low > tall)[11]))
    labels = np.where(crown, (cols >= crossing + shift).astype(np.intp), -1)
    return labels, np.where(crown, canopy, np.nan), crossing


def test_paraboloid_fit_recovers_a_dome() -> None:
    y, x = (v.ravel() * CELL for v in np.mgrid[0:15, 0:15].astype(float))
    z = _dome(x, y, 5, 4, 20, 6)
    fits = fit_paraboloids(np.zeros(len(x), np.intp), (x, y), z, 1)
    assert np.allclose(fits.at(np.zeros(len(x), np.intp), x, y), z)
    assert fits.beta[0, 3] == pytest.approx(-0.6 * 20 / 36)


@pytest.mark.parametrize("shift", [1, 2, 3, 4])
def test_a_boundary_drawn_into_the_lower_crown_moves_back_to_the_crossing(shift: int) -> None:
    labels, canopy, crossing = _tall_and_low(shift)
    out = crossed_boundaries(labels, canopy, CELL, min_area=4.0)
    first_low = int(np.argmax(out[11] == 1))
    assert abs(first_low - crossing) <= 1
    # the low crown gained the cells the tall one had taken, and no cell left the crowns
    assert (out == 1).sum() > (labels == 1).sum()
    assert np.array_equal(out >= 0, labels >= 0)


def test_small_crowns_and_none_move_nothing() -> None:
    labels, canopy, _ = _tall_and_low(3)
    # the low crown's area is under the least area: no boundary of it moves
    low_area = (labels == 1).sum() * CELL**2
    assert np.array_equal(crossed_boundaries(labels, canopy, CELL, min_area=low_area + 1.0), labels)
    empty = np.full((5, 5), -1, np.intp)
    assert np.array_equal(crossed_boundaries(empty, np.full((5, 5), np.nan), CELL, min_area=1.0), empty)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_crowns_keep_their_tops_and_cells_and_a_second_pass_moves_nothing(seed: int) -> None:
    rng = np.random.default_rng(seed)
    rows, cols = np.mgrid[0:30, 0:30]
    x, y = (cols + 0.5) * CELL, (rows + 0.5) * CELL
    tops = rng.uniform(2, 19, size=(4, 2))
    heights, radii = rng.uniform(6, 25, 4), rng.uniform(2, 5, 4)
    domes = np.stack([_dome(x, y, *t, h, r) for t, h, r in zip(tops, heights, radii)])
    canopy = domes.max(axis=0) + rng.normal(0, 0.2, x.shape)
    crown = canopy > 3.0
    # a wrong but plausible segmentation: the nearest top, not the highest dome
    nearest = np.argmin([np.hypot(x - tx, y - ty) for tx, ty in tops], axis=0)
    labels = np.where(crown, nearest, -1).astype(np.intp)
    heights_in = np.where(crown, canopy, np.nan)
    out = crossed_boundaries(labels, heights_in, CELL, min_area=2.0)
    assert np.array_equal(out >= 0, labels >= 0)
    for k in np.unique(labels[labels >= 0]):
        top = np.nanargmax(np.where(labels == k, heights_in, np.nan))
        assert out.ravel()[top] == k
        # and no crown gained a cell above its top: every tree keeps its height
        assert np.nanmax(np.where(out == k, heights_in, np.nan)) == heights_in.ravel()[top]
    assert np.array_equal(crossed_boundaries(out, heights_in, CELL, min_area=2.0), out)
