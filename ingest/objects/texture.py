"""Texture of a height raster (seed §2.2): the second derivative and the largest slope.

Both are taken over each cell and its eight neighbours. The second derivative is the largest
departure, in metres, of the cell from the straight line through an opposite pair of
neighbours (the four lines through the cell): a plane roof, flat or tilted, has none; a roof
ridge has one along the ridge only; a crown has them everywhere. Metres rather than m⁻¹ keep
the measure's meaning when the cell size follows the survey's density.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tdb.median import median_filter

# Opposite neighbour pairs (row, col offsets) and their distance in cells.
_LINES = (((0, 1), 1.0), ((1, 0), 1.0), ((1, 1), np.sqrt(2)), ((1, -1), np.sqrt(2)))


def _shifted(p: NDArray[np.float64], dr: int, dc: int) -> NDArray[np.float64]:
    """Each cell's neighbour at (dr, dc), read from ``p``, the raster padded by its edge cells."""
    rows, cols = p.shape[0] - 2, p.shape[1] - 2
    return p[1 + dr : 1 + dr + rows, 1 + dc : 1 + dc + cols]


def second_derivative(z: NDArray[np.float64]) -> NDArray[np.float64]:
    """Largest |z(−) − 2 z + z(+)| / 2 over the four lines through each cell (m)."""
    p = np.pad(z, 1, mode="edge")
    out = np.zeros(z.shape)
    for (dr, dc), _ in _LINES:
        d2 = np.abs(_shifted(p, dr, dc) + _shifted(p, -dr, -dc) - 2 * z) / 2
        np.maximum(out, d2, out=out)
    return out


def max_slope(z: NDArray[np.float64], cell: float) -> NDArray[np.float64]:
    """Largest |dz| / distance to any of the eight neighbours (rise over run)."""
    p = np.pad(z, 1, mode="edge")
    out = np.zeros(z.shape)
    for (dr, dc), steps in _LINES:
        for sign in (1, -1):
            s = np.abs(_shifted(p, sign * dr, sign * dc) - z) / (steps * cell)
            np.maximum(out, s, out=out)
    return out


def median_texture(z: NDArray[np.float64], cell: float, *, size: int = 3) -> NDArray[np.float64]:
    """(rows, cols, 2) median-filtered second derivative and largest slope.

    The median removes the large values at roof edges, chimneys and antennas that would
    otherwise read as vegetation.
    """
    return np.stack(
        [median_filter(t, size, mode="nearest") for t in (second_derivative(z), max_slope(z, cell))],
        axis=-1,
    )
