"""Sensor noise of the ground: the scatter of ground points about their local plane."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree


def ground_noise(ground_xyz: NDArray[np.float64], *, k: int = 10, sample: int = 20_000, seed: int = 0) -> float:
    """Robust σ (m) of ground heights about planes fitted to their ``k`` nearest neighbours.

    The smallest eigenvalue of a neighbourhood's covariance is the variance
    across its best plane; the median over a sample of neighbourhoods ignores
    breaks of slope and leftover objects.
    """
    xyz = np.asarray(ground_xyz, float)
    if len(xyz) <= k:
        return 0.0
    rng = np.random.default_rng(seed)
    pick = rng.choice(len(xyz), min(sample, len(xyz)), replace=False)
    _, nb = cKDTree(xyz[:, :2]).query(xyz[pick, :2], k=k)
    pts = xyz[nb]
    centred = pts - pts.mean(axis=1, keepdims=True)
    cov = np.einsum("nki,nkj->nij", centred, centred) / (k - 3)
    smallest = np.linalg.eigvalsh(cov)[:, 0]
    return float(np.sqrt(np.median(np.maximum(smallest, 0.0))))
