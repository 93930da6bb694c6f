"""Crown boundaries moved to where the crowns' surfaces cross.

Seen from above, the canopy is the upper envelope of its crowns: where two crowns meet, each
cell shows the one that stands higher there. The climb of :mod:`climb` on a smoothed canopy
draws the line between a tall crown and a lower one beside it too far into the lower one,
since smoothing spreads the tall crown's flank outwards; the tall crown's diameter then grows
by what the low one loses. Here each crown's shape is a paraboloid of revolution fitted to its
cells (:mod:`crowns`), and a cell at a boundary passes to the neighbouring crown whose
paraboloid stands higher there than its own crown's and explains its height better. The
paraboloids are fitted again and the boundaries moved until none moves.

Only crowns of at least ``min_area`` take part, on either side: a smaller segment's paraboloid
is fitted to too few cells to say where its surface runs beyond them. A crown keeps its
highest cell and gains none higher, so no tree's position or height changes, only its outline
and diameter.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ingest.objects.crowns import Paraboloids, fit_paraboloids

MAX_STEPS = 100  # each step moves a boundary by one cell at most; the moves stop long before
NEIGHBOURS = ((-1, 0), (1, 0), (0, -1), (0, 1))


def crossed_boundaries(
    labels: NDArray[np.intp], canopy: NDArray[np.float64], cell: float, *, min_area: float
) -> NDArray[np.intp]:
    """``labels`` (segments 0 … n − 1 of the canopy, −1 elsewhere) with the boundaries between
    crowns of at least ``min_area`` m² moved to where their paraboloids cross.

    Parameters
    ----------
    labels : the crown segments of a grid of ``cell`` m.
    canopy : the crown surface's heights on the same grid.
    cell : the grid's cell (m).
    min_area : the least crown area (m²) whose paraboloid moves a boundary.
    """
    out = np.array(labels, np.intp, copy=True)
    rows, cols = np.nonzero((out >= 0) & np.isfinite(canopy))
    if len(rows) == 0:
        return out
    n = int(out.max()) + 1
    x, y = ((cols + 0.5) * cell).astype(np.float64), ((rows + 0.5) * cell).astype(np.float64)
    z = np.asarray(canopy[rows, cols], np.float64)
    lab = out[rows, cols]
    order = np.lexsort((z, lab))
    tops = order[np.r_[lab[order][1:] != lab[order][:-1], True]]
    apex = np.full(n, -np.inf)
    apex[lab[tops]] = z[tops]
    others = _neighbours(out, rows, cols)
    fits = fit_paraboloids(lab, (x, y), z, n)
    for _ in range(MAX_STEPS):
        moved = _crossing(lab, others, (x, y, z), fits, apex, min_cells=min_area / cell**2)
        moved[tops] = lab[tops]
        if np.array_equal(moved, lab):
            break
        changed = np.unique(np.r_[lab[moved != lab], moved[moved != lab]])
        lab = moved
        fits = _refitted(fits, changed, lab, (x, y), z)
    out[rows, cols] = lab
    return out


def _neighbours(
    labels: NDArray[np.intp], rows: NDArray[np.intp], cols: NDArray[np.intp]
) -> list[tuple[NDArray[np.intp], NDArray[np.intp]]]:
    """Per 4-neighbour of each moving cell (``rows``, ``cols``): where it is a moving cell, its
    place among them (−1 otherwise), and else its label, which never changes."""
    place = np.full(labels.shape, -1, np.intp)
    place[rows, cols] = np.arange(len(rows))
    out = []
    for dr, dc in NEIGHBOURS:
        r, c = rows + dr, cols + dc
        inside = (r >= 0) & (r < labels.shape[0]) & (c >= 0) & (c < labels.shape[1])
        r, c = np.where(inside, r, 0), np.where(inside, c, 0)
        out.append((np.where(inside, place[r, c], -1), np.where(inside, labels[r, c], -1)))
    return out


def _refitted(
    fits: Paraboloids,
    changed: NDArray[np.intp],
    lab: NDArray[np.intp],
    xy: tuple[NDArray[np.float64], NDArray[np.float64]],
    z: NDArray[np.float64],
) -> Paraboloids:
    """``fits`` with the paraboloids of the segments ``changed`` fitted again. A segment's sums
    run over its own cells in their order, so a refit of some segments gives each the bits a fit
    of all gives it."""
    mine = np.flatnonzero(np.isin(lab, changed))
    new = fit_paraboloids(lab[mine], (xy[0][mine], xy[1][mine]), z[mine], len(fits.count))
    beta, centre, count = fits.beta.copy(), fits.centre.copy(), fits.count.copy()
    beta[changed], centre[changed], count[changed] = new.beta[changed], new.centre[changed], new.count[changed]
    return Paraboloids(beta, centre, count)


def _crossing(
    lab: NDArray[np.intp],
    neighbours: list[tuple[NDArray[np.intp], NDArray[np.intp]]],
    xyz: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]],
    fits: Paraboloids,
    apex: NDArray[np.float64],
    *,
    min_cells: float,
) -> NDArray[np.intp]:
    """One step: each crown cell's segment after the moves across its 4-neighbour boundaries
    (``neighbours``: :func:`_neighbours`), the segments' paraboloids ``fits``; a cell joins no
    crown whose top (``apex``, per segment) it stands above."""
    x, y, z = xyz
    # a paraboloid opening upwards is no crown's, and one of a few cells no shape beyond them
    shaped = (fits.beta[:, 3] < 0) & (fits.count >= max(min_cells, 1.0))
    others = [np.where(place >= 0, lab[place], fixed) for place, fixed in neighbours]
    # only a cell with a shaped crown's neighbour of another shaped crown can move
    edge = shaped[lab] & np.logical_or.reduce([(o >= 0) & (o != lab) & shaped[np.maximum(o, 0)] for o in others])
    at_edge = np.flatnonzero(edge)
    best = lab.copy()
    if len(at_edge) == 0:
        return best
    mine, xe, ye, ze = lab[at_edge], x[at_edge], y[at_edge], z[at_edge]
    own = fits.at(mine, xe, ye)
    choice, best_error = mine.copy(), np.abs(own - ze)
    for o in others:
        other = o[at_edge]
        k = np.maximum(other, 0)
        there = fits.at(k, xe, ye)
        error = np.abs(there - ze)
        better = (other >= 0) & (other != mine) & shaped[k] & (ze <= apex[k])
        better &= (there > own) & (error < best_error)
        choice = np.where(better, other, choice)
        best_error = np.where(better, error, best_error)
    best[at_edge] = choice
    return best
