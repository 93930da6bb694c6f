"""Vectorised plan-view geometry used by the scene generator."""

from __future__ import annotations

import itertools

import numpy as np
from numpy.typing import NDArray


def distance_to_polyline(
    x: NDArray[np.float64], y: NDArray[np.float64], coords: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Shortest plan distance from each point (x, y) to the polyline ``coords`` (M, 2)."""
    best = np.full(x.shape, np.inf)
    for (ax, ay), (bx, by) in itertools.pairwise(coords):
        dx, dy = bx - ax, by - ay
        length2 = dx * dx + dy * dy
        t = np.zeros_like(x) if length2 == 0 else np.clip(((x - ax) * dx + (y - ay) * dy) / length2, 0, 1)
        np.minimum(best, np.hypot(x - (ax + t * dx), y - (ay + t * dy)), out=best)
    return best


def project_on_polyline(
    x: NDArray[np.float64], y: NDArray[np.float64], coords: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """For each point (x, y), its plan distance to the polyline ``coords`` (M, 2), where along the
    line its nearest point lies (0 at the first vertex, 1 at the last) and on which side it lies
    (+1 left of the line's direction, −1 right)."""
    best = np.full(x.shape, np.inf)
    at = np.zeros(x.shape)
    side = np.ones(x.shape)
    run = 0.0
    seg = np.hypot(*np.diff(coords, axis=0).T)
    total = float(seg.sum()) or 1.0
    for ((ax, ay), (bx, by)), length in zip(itertools.pairwise(coords), seg):
        dx, dy = bx - ax, by - ay
        t = np.zeros_like(x) if length == 0 else np.clip(((x - ax) * dx + (y - ay) * dy) / length**2, 0, 1)
        d = np.hypot(x - (ax + t * dx), y - (ay + t * dy))
        closer = d < best
        best = np.where(closer, d, best)
        at = np.where(closer, (run + t * length) / total, at)
        side = np.where(closer, np.where(dx * (y - ay) - dy * (x - ax) >= 0, 1.0, -1.0), side)
        run += float(length)
    return best, at, side


def wander(
    start: tuple[float, float],
    heading: float,
    length: float,
    *,
    curvature: float,
    rng: np.random.Generator,
    step: float = 2.0,
) -> NDArray[np.float64]:
    """A polyline from ``start``: straight where ``curvature`` is 0, else gently curving."""
    n = max(2, int(length / step) + 1)
    s = np.linspace(0, length, n)
    phase = rng.uniform(0, 2 * np.pi)
    wavelength = rng.uniform(60, 160)
    theta = heading + curvature * np.sin(2 * np.pi * s / wavelength + phase)
    ds = np.diff(s, prepend=0.0)
    x = start[0] + np.cumsum(ds * np.cos(theta))
    y = start[1] + np.cumsum(ds * np.sin(theta))
    return np.column_stack([x, y])


def in_bbox(
    x: NDArray[np.float64], y: NDArray[np.float64], bounds: tuple[float, float, float, float], margin: float
) -> NDArray[np.bool_]:
    x0, y0, x1, y1 = bounds
    return (x >= x0 - margin) & (x <= x1 + margin) & (y >= y0 - margin) & (y <= y1 + margin)
