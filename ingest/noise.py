"""Sensor noise of the ground: the scatter of ground points about their local plane, and the
survey's flat threshold from it.

The threshold is measured on one square of the survey, the :data:`PILOT_SQUARE` m square of a
fixed lattice holding the most points: a definition that does not depend on how the work is cut,
so that an ingest block by block and one in one piece find the same threshold (the blocks'
ground there is the one-piece ground up to their buffer's rare differences, the sample of
neighbourhoods is chosen by the points' own coordinates, and the threshold is whole
centimetres).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from tdb.bbox import points_in_box
from tdb.kdtree import plan_tree
from tdb.tiles import key_pair, tile_key

MIN_FLAT = 0.10  # m: below this a threshold would call noise a form
NOISE_FACTOR = 5.0  # flat threshold = this × the measured ground noise


def ground_noise(ground_xyz: NDArray[np.float64], *, k: int = 10, sample: int = 20_000, seed: int = 0) -> float:
    """Robust σ (m) of ground heights about planes fitted to their ``k`` nearest neighbours.

    The smallest eigenvalue of a neighbourhood's covariance is the variance
    across its best plane; the median over a sample of about ``sample`` neighbourhoods ignores
    breaks of slope and leftover objects. Whether a point is sampled depends on its coordinates
    alone (and ``seed``), not on the order or the company it comes in.
    """
    return ground_noises(ground_xyz, (50.0,), k=k, sample=sample, seed=seed)[0]


def ground_noises(
    ground_xyz: NDArray[np.float64],
    quantiles: tuple[float, ...],
    *,
    k: int = 10,
    sample: int = 20_000,
    seed: int = 0,
    tree: cKDTree | None = None,
) -> tuple[float, ...]:
    """The spread of :func:`ground_noise` at each of ``quantiles`` (percent) of the neighbourhoods,
    from one sample of them: 50 is the ground noise; a low one (:data:`QUIET`) is the spread of the
    quietest neighbourhoods, bare ground's, where vegetation taken for ground widens the median's.
    ``tree``: :func:`tdb.kdtree.plan_tree` of ``ground_xyz``, where the caller has one."""
    xyz = np.asarray(ground_xyz, float)
    if len(xyz) <= k:
        return tuple(0.0 for _ in quantiles)
    pick = _sample(xyz, sample, seed)
    _, nb = (tree if tree is not None else plan_tree(xyz[:, :2])).query(xyz[pick, :2], k=k)
    pts = xyz[nb]
    centred = pts - pts.mean(axis=1, keepdims=True)
    cov = centred.transpose(0, 2, 1) @ centred / (k - 3)
    smallest = np.maximum(np.linalg.eigvalsh(cov)[:, 0], 0.0)
    return tuple(float(np.sqrt(np.percentile(smallest, q))) for q in quantiles)


QUIET = 25.0  # percent: the quietest quarter of a survey's neighbourhoods is bare ground's


PILOT_SQUARE = 256.0  # m: the squares the flat threshold's noise is measured in
THRESHOLD_STEP = 0.01  # m: the flat threshold in whole centimetres


def coordinate_hash(xy: NDArray[np.float64], seed: int = 0) -> NDArray[np.uint64]:
    """A 64-bit hash of each point's x and y (SplitMix64's mixer): a choice made by it depends on
    where a point lies, not on its order or the company it comes in."""
    bits = np.ascontiguousarray(np.asarray(xy, np.float64)[:, :2]).view(np.uint64)
    with np.errstate(over="ignore"):
        h = bits[:, 0] * np.uint64(0x9E3779B97F4A7C15) ^ bits[:, 1] ^ np.uint64(seed)
        h = (h ^ (h >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        h = (h ^ (h >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        h ^= h >> np.uint64(31)
    return h


def _sample(xyz: NDArray[np.float64], size: int, seed: int) -> NDArray[np.intp]:
    """About ``size`` of the points, each chosen by :func:`coordinate_hash`."""
    if len(xyz) <= size:
        return np.arange(len(xyz))
    keep = coordinate_hash(xyz, seed) < np.uint64(int(size / len(xyz) * 2.0**64))
    return np.flatnonzero(keep)


def square_counts(x: NDArray[np.float64], y: NDArray[np.float64]) -> dict[tuple[int, int], int]:
    """Points per :data:`PILOT_SQUARE` m square (keyed by its indices)."""
    i = np.floor(np.asarray(x) / PILOT_SQUARE).astype(np.int64)
    j = np.floor(np.asarray(y) / PILOT_SQUARE).astype(np.int64)
    keys, counts = np.unique(tile_key(i, j), return_counts=True)
    ki, kj = key_pair(keys)
    return {(int(a), int(b)): int(c) for a, b, c in zip(ki, kj, counts)}


def fullest_square(counts: dict[tuple[int, int], int]) -> tuple[float, float, float, float]:
    """The box of the square holding the most points (the first in key order of equals)."""
    if not counts:
        raise ValueError("no points to find a square in")
    most = max(counts.values())
    i, j = min(k for k, c in counts.items() if c == most)
    return (i * PILOT_SQUARE, j * PILOT_SQUARE, (i + 1) * PILOT_SQUARE, (j + 1) * PILOT_SQUARE)


def flat_threshold_for(noise: float) -> float:
    """The height range (m) under which a tile is flat: ``NOISE_FACTOR`` × the ground noise, at
    least ``MIN_FLAT``, in whole centimetres."""
    return round(max(MIN_FLAT, NOISE_FACTOR * noise) / THRESHOLD_STEP) * THRESHOLD_STEP


def pilot_threshold(ground_xyz: NDArray[np.float64], square: tuple[float, float, float, float]) -> float:
    """The survey's flat threshold from the noise of its ground points in ``square``."""
    xyz = np.asarray(ground_xyz, float)
    return flat_threshold_for(ground_noise(xyz[points_in_box(xyz[:, 0], xyz[:, 1], square, closed=False)]))
