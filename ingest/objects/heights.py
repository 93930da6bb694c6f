"""Heights above the ground model, and the highest of them per cell."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ingest.ground.grids import Grid
from tdb.raster import Raster
from tdb.sort import scatter_max


def above_ground(xyz: NDArray[np.float64], dtm: Raster) -> NDArray[np.float64]:
    """Height (m) of each point over the dense ground model; NaN where the model has no data."""
    return xyz[:, 2] - dtm.sample(xyz[:, 0], xyz[:, 1])


def flat_cells(grid: Grid, xy: NDArray[np.float64]) -> NDArray[np.intp]:
    """The flat index (row × columns + column) of each point's cell of ``grid``."""
    row, col = grid.index(xy)
    return row * grid.shape[1] + col


@dataclass(frozen=True)
class TopRaster:
    """The highest point per cell: its height above ground and its index (rows south to north).

    ``height`` is NaN and ``index`` −1 where a cell holds no point with a known height.
    """

    grid: Grid
    height: NDArray[np.float64]
    index: NDArray[np.intp]

    @classmethod
    def of(
        cls, grid: Grid, xy: NDArray[np.float64], h: NDArray[np.float64], *, cells: NDArray[np.intp] | None = None
    ) -> TopRaster:
        """The raster of the points ``xy`` with heights ``h``; ``cells``: their flat cells
        (:func:`flat_cells`), where the caller has them."""
        known = np.flatnonzero(np.isfinite(h))
        flat = flat_cells(grid, xy[known]) if cells is None else cells[known]
        size = grid.shape[0] * grid.shape[1]
        # Two passes over the points and no sort: the highest per cell, then which point it is
        # (of equal heights, the last in the input).
        top = np.full(size, -np.inf)
        scatter_max(top, flat, h[known])
        index = np.full(size, -1, np.intp)
        at_top = h[known] == top[flat]
        index[flat[at_top]] = known[at_top]
        height = np.where(index >= 0, top, np.nan)
        return cls(grid, height.reshape(grid.shape), index.reshape(grid.shape))

    def cells_of(self, xy: NDArray[np.float64]) -> NDArray[np.intp]:
        """Flat cell index of each point."""
        return flat_cells(self.grid, xy)

    def plane_departure(self, xy: NDArray[np.float64], cells: NDArray[np.bool_]) -> NDArray[np.float64]:
        """At the ``cells`` asked for, the root-mean-square departure (m) of top points from
        their least-squares plane, at the points' true positions: the top points of the cell and
        its eight neighbours, or of the cell and the neighbours on one side of it (one of eight
        halves of the 3 × 3 window, along a row, a column or a diagonal), whichever lie closest
        to a plane. NaN elsewhere and where no window holds four points.

        The second derivative of a raster reads a point's place in its cell as relief: a cell's
        highest point lies anywhere in it, so on a roof of slope s the raster is off the plane
        by up to s × half a cell and a steep roof looks as rough as a crown. The plane through
        the points themselves is exact on any roof plane, flat or steep. A ridge or an eave is
        a plane's edge: a cell on it lies on one plane with the neighbours on one side, where a
        crown's top points depart from a plane whichever side is taken. The residual is divided
        by the plane's degrees of freedom, so that windows of six and of nine points read alike.
        """
        rows, cols = self.grid.shape
        out = np.full((rows, cols), np.nan)
        at = np.flatnonzero(cells.ravel())
        if len(at) == 0:
            return out
        base = float(np.nanmedian(self.height.ravel()[at]))
        best = np.full(len(at), np.inf)
        for lo in range(0, len(at), _CHUNK):
            moments = self._window_moments(xy, at[lo : lo + _CHUNK], base)
            for members in _WINDOWS:
                total = sum((moments[k] for k in members), np.zeros_like(moments[0]))
                best[lo : lo + _CHUNK] = np.minimum(best[lo : lo + _CHUNK], _plane_rms(total, self.grid.cell))
        out.ravel()[at] = np.where(np.isfinite(best), best, np.nan)
        return out

    def _window_moments(
        self, xy: NDArray[np.float64], at: NDArray[np.intp], base: float
    ) -> list[NDArray[np.float64]]:
        """Per offset of :data:`_OFFSETS`, the (10, len(at)) moments n, Σu, Σv, Σz, Σuu, Σuv, Σvv,
        Σuz, Σvz, Σzz of the top point of that neighbour of each cell ``at`` (u, v about the
        cell's centre, z about ``base`` so that the sums stay well conditioned)."""
        rows, cols = self.grid.shape
        r, c = np.divmod(at, cols)
        xs, ys = self.grid.centres()
        index, height = self.index.ravel(), self.height.ravel()
        out = []
        for dr, dc in _OFFSETS:
            rr, cc = r + dr, c + dc
            inside = (rr >= 0) & (rr < rows) & (cc >= 0) & (cc < cols)
            flat = np.where(inside, rr * cols + cc, 0)
            k = np.where(inside, index[flat], -1)
            w = k >= 0
            kk = np.maximum(k, 0)
            u = np.where(w, xy[kk, 0] - xs[c], 0.0)
            v = np.where(w, xy[kk, 1] - ys[r], 0.0)
            z = np.where(w, height[flat] - base, 0.0)
            out.append(np.stack([w, u, v, z, u * u, u * v, v * v, u * z, v * z, z * z]))
        return out


_CHUNK = 200_000  # cells whose window moments are held at once
_OFFSETS = [(dr, dc) for dr in (-1, 0, 1) for dc in (-1, 0, 1)]
# The whole 3 × 3 window and its eight halves of six cells: each side of a row, of a column and
# of either diagonal through the cell.
_WINDOWS = [
    [k for k, (dr, dc) in enumerate(_OFFSETS) if side(dr, dc)]
    for side in (
        lambda dr, dc: True,
        lambda dr, dc: dr >= 0,
        lambda dr, dc: dr <= 0,
        lambda dr, dc: dc >= 0,
        lambda dr, dc: dc <= 0,
        lambda dr, dc: dr + dc >= 0,
        lambda dr, dc: dr + dc <= 0,
        lambda dr, dc: dr - dc >= 0,
        lambda dr, dc: dr - dc <= 0,
    )
]


def _plane_rms(moments: NDArray[np.float64], cell: float) -> NDArray[np.float64]:
    """RMS residual (m) of the least-squares plane through points given by their moments (see
    :meth:`TopRaster._window_moments`), per degree of freedom; inf under four points."""
    n, su, sv, sz, suu, suv, svv, suz, svz, szz = moments
    m = np.maximum(n, 1)
    cuu, cuv, cvv = suu - su * su / m, suv - su * sv / m, svv - sv * sv / m
    cuz, cvz, czz = suz - su * sz / m, svz - sv * sz / m, szz - sz * sz / m
    det = cuu * cvv - cuv * cuv
    ok = (n >= 4) & (det > 1e-6 * cell**4)
    safe = np.where(ok, det, 1.0)
    gx = (cvv * cuz - cuv * cvz) / safe
    gy = (cuu * cvz - cuv * cuz) / safe
    rss = np.maximum(czz - gx * cuz - gy * cvz, 0.0)
    return np.where(ok, np.sqrt(rss / np.maximum(n - 3, 1)), np.inf)
