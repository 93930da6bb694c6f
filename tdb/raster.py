"""A georeferenced raster: the dense ground model and everything drawn from it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tdb.rasterise import PostGrid

MAX_CELLS = 400_000_000  # ~3 GB of float64: beyond this an extent is absurd for its cell size


@dataclass(frozen=True)
class Raster:
    """Cell values with rows running north to south, as GeoTIFFs store them.

    ``x0`` is the west edge, ``y1`` the north edge, ``cell`` the square cell
    size in metres; NaN marks no data.
    """

    data: NDArray[np.float64]
    x0: float
    y1: float
    cell: float
    crs: Any = None

    @property
    def shape(self) -> tuple[int, int]:
        return (int(self.data.shape[0]), int(self.data.shape[1]))

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        rows, cols = self.shape
        return (self.x0, self.y1 - rows * self.cell, self.x0 + cols * self.cell, self.y1)

    def centres(self) -> tuple[NDArray[np.floating], NDArray[np.floating]]:
        """x of each column centre and y of each row centre (north first)."""
        rows, cols = self.shape
        return self.x0 + (np.arange(cols) + 0.5) * self.cell, self.y1 - (np.arange(rows) + 0.5) * self.cell

    def posts(self) -> PostGrid:
        """The cell centres as a :class:`tdb.rasterise.PostGrid` (surfaces are rasterised onto it)."""
        rows, cols = self.shape
        return PostGrid(self.x0 + 0.5 * self.cell, self.y1 - 0.5 * self.cell, self.cell, rows, cols)

    def sample(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Bilinear value at points; NaN outside or next to no-data.

        A neighbour with zero weight does not count, so a point on a post (or on the
        line between two posts) keeps its value beside a hole: 0 × NaN would be NaN.
        """
        fc = self._snap((np.asarray(x, float) - self.x0) / self.cell - 0.5)
        fr = self._snap((self.y1 - np.asarray(y, float)) / self.cell - 0.5)
        rows, cols = self.shape
        # The cell's lower corner is held one post inside the last row and column, so that its
        # other corners are posts too: a point on the last post takes it with weight one.
        with np.errstate(invalid="ignore"):
            c0 = np.clip(np.floor(fc).astype(np.intp), 0, max(cols - 2, 0))
            r0 = np.clip(np.floor(fr).astype(np.intp), 0, max(rows - 2, 0))
        tc, tr = fc - c0, fr - r0
        inside = (fc >= 0) & (fr >= 0) & (fc <= cols - 1) & (fr <= rows - 1)
        flat = r0 * cols + c0
        right, down = int(cols > 1), cols * int(rows > 1)
        total = np.zeros(np.shape(fc))
        corners = (
            (0, (1 - tr) * (1 - tc)),
            (right, (1 - tr) * tc),
            (down, tr * (1 - tc)),
            (down + right, tr * tc),
        )
        for offset, w in corners:
            total += np.where(w > 0, w * np.take(self.data, flat + offset), 0.0)
        return np.where(inside, total, np.nan)

    @staticmethod
    def _snap(f: NDArray[np.float64]) -> NDArray[np.float64]:
        """Grid coordinates within round-off of a whole post are that post."""
        r = np.round(f)
        return np.where(np.abs(f - r) < 1e-6, r, f)
