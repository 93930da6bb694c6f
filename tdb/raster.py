"""A georeferenced raster: the dense ground model and everything drawn from it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray


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

    def sample(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Bilinear value at points; NaN outside or next to no-data."""
        from scipy import ndimage

        fc = (np.asarray(x) - self.x0) / self.cell - 0.5
        fr = (self.y1 - np.asarray(y)) / self.cell - 0.5
        return ndimage.map_coordinates(self.data, [fr, fc], order=1, mode="constant", cval=np.nan)
