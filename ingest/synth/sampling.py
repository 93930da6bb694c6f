"""Airborne LiDAR returns from a synthetic scene, block by block.

Pulses fall uniformly at the requested density. A pulse that meets a roof
gives one building return; one that meets a crown gives one or two vegetation
returns and, often, a last return from the ground beneath; the rest hit the
ground. Heights carry sensor noise, and a few low outliers are added.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import shapely
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from ingest.synth.scene import Scene
from ingest.synth.surface import ground_height
from tdb.cloud import BUILDING, GROUND, NOISE, VEGETATION, PointCloud
from tdb.errors import InputError
from tdb.units import as_crs

BLOCK = 250.0
MIN_DENSITY, MAX_DENSITY = 0.05, 50.0
NOISE_SIGMA = 0.03
LOW_NOISE_SHARE = 2e-4
GROUND_BELOW_CROWN = 0.6  # chance that a pulse into a crown also returns from the ground
VEGETATION_CLEARANCE = 0.1  # m: the lowest vegetation return over the ground


def blocks(scene: Scene) -> Iterator[tuple[int, int, tuple[float, float, float, float]]]:
    x0, y0, x1, y1 = scene.bounds
    nx, ny = int(np.ceil((x1 - x0) / BLOCK)), int(np.ceil((y1 - y0) / BLOCK))
    for i in range(nx):
        for j in range(ny):
            yield (
                i,
                j,
                (x0 + i * BLOCK, y0 + j * BLOCK, min(x1, x0 + (i + 1) * BLOCK), min(y1, y0 + (j + 1) * BLOCK)),
            )


def sample_block(
    scene: Scene, bounds: tuple[float, float, float, float], *, density: float, rng: np.random.Generator
) -> dict[str, NDArray]:
    """Returns of the pulses falling in ``bounds``, as column arrays."""
    bx0, by0, bx1, by1 = bounds
    n = int(rng.poisson(density * (bx1 - bx0) * (by1 - by0)))
    x = rng.uniform(bx0, bx1, n)
    y = rng.uniform(by0, by1, n)
    zg = ground_height(scene, x, y)
    cols: dict[str, list[NDArray]] = {k: [] for k in ("x", "y", "z", "cls", "rn", "nr")}

    def emit(mask_or_idx: NDArray, z: NDArray, cls: int, rn: NDArray | int, nr: NDArray | int) -> None:
        xs, ys = x[mask_or_idx], y[mask_or_idx]
        m = len(xs)
        cols["x"].append(xs)
        cols["y"].append(ys)
        cols["z"].append(z + rng.normal(0, NOISE_SIGMA, m))
        cols["cls"].append(np.full(m, cls, np.uint8))
        cols["rn"].append(np.broadcast_to(np.asarray(rn, np.uint8), (m,)).copy())
        cols["nr"].append(np.broadcast_to(np.asarray(nr, np.uint8), (m,)).copy())

    free = np.ones(n, bool)
    roof = np.full(n, np.nan)
    for b in scene.buildings:
        inside = free & shapely.contains_xy(b.footprint, x, y)
        if not inside.any():
            continue
        z = np.full(int(inside.sum()), _base(scene, b.footprint) + b.height)
        if b.roof == "gable":
            z += b.ridge_height * _gable(b.footprint, x[inside], y[inside])
        roof[inside] = z
        free &= ~inside
    hit_roof = ~np.isnan(roof)
    emit(hit_roof, roof[hit_roof], BUILDING, 1, 1)

    crowns = _crown_hits(scene, x, y, zg, free)
    if crowns is not None:
        idx, top = crowns
        free[idx] = False
        k = len(idx)
        depth1 = rng.exponential(0.4, k)
        second = rng.random(k) < 0.4
        ground = rng.random(k) < GROUND_BELOW_CROWN
        nret = 1 + second + ground
        # A crown's returns stay above the ground under it: near a crown's rim the first return's
        # depth into the crown and the second's below it could reach under the terrain, and the
        # filters then took those points for pits in the ground.
        first = np.maximum(top - depth1, zg[idx] + VEGETATION_CLEARANCE)
        emit(idx, first, VEGETATION, 1, nret)
        s_idx = idx[second]
        drop = rng.uniform(1, 5, len(s_idx))  # into the crown, and not closer than 0.5 m to the ground
        below = first[second] - np.minimum(drop, first[second] - zg[s_idx] - 0.5)
        emit(s_idx, np.maximum(below, zg[s_idx] + VEGETATION_CLEARANCE), VEGETATION, 2, nret[second])
        g_idx = idx[ground]
        emit(g_idx, zg[g_idx], GROUND, nret[ground], nret[ground])
    emit(free, zg[free], GROUND, 1, 1)

    low = rng.random(n) < LOW_NOISE_SHARE
    emit(low, zg[low] - rng.uniform(1, 30, int(low.sum())), NOISE, 1, 1)
    return {k: np.concatenate(v) if v else np.empty(0) for k, v in cols.items()}


def _base(scene: Scene, footprint: shapely.Polygon, *, step: float = 1.0) -> float:
    """The height a building stands on: the highest ground under its footprint (its corners and
    a grid ``step`` m apart inside). On a slope its downhill walls are the taller; a base taken
    at one point would put the uphill part of a large roof under the ground."""
    x0, y0, x1, y1 = footprint.bounds
    mx, my = np.meshgrid(np.arange(x0, x1 + step, step), np.arange(y0, y1 + step, step))
    gx, gy = mx.ravel(), my.ravel()
    inside = shapely.contains_xy(footprint, gx, gy)
    corners = np.asarray(footprint.exterior.coords)
    x = np.concatenate([gx[inside], corners[:, 0]])
    y = np.concatenate([gy[inside], corners[:, 1]])
    return float(ground_height(scene, x, y).max())


def _gable(footprint: shapely.Polygon, x: NDArray, y: NDArray) -> NDArray:
    """0 at the eaves, 1 on the ridge, which runs along the long side."""
    rect = footprint.minimum_rotated_rectangle
    c = np.asarray(rect.exterior.coords)[:4]
    e1, e2 = c[1] - c[0], c[2] - c[1]
    across = e2 if np.hypot(*e1) >= np.hypot(*e2) else e1
    half = np.hypot(*across) / 2
    unit = across / (2 * half)
    centre = c.mean(axis=0)
    d = np.abs((x - centre[0]) * unit[0] + (y - centre[1]) * unit[1])
    return np.clip(1 - d / half, 0, 1)


def _crown_hits(
    scene: Scene, x: NDArray, y: NDArray, zg: NDArray, free: NDArray
) -> tuple[NDArray, NDArray] | None:
    if not scene.trees:
        return None
    centres = np.array([[t.x, t.y] for t in scene.trees])
    radius = np.array([t.crown_radius for t in scene.trees])
    height = np.array([t.height for t in scene.trees])
    candidates = np.flatnonzero(free)
    dist, which = cKDTree(centres).query(np.column_stack([x[candidates], y[candidates]]))
    inside = dist < radius[which]
    if not inside.any():
        return None
    idx = candidates[inside]
    t = which[inside]
    u = dist[inside] / radius[t]
    crown_depth = 0.6 * height[t]
    top = zg[idx] + height[t] - crown_depth * u**2
    return idx, top


def sample(scene: Scene, *, density: float, seed: int = 0) -> PointCloud:
    """All returns of ``scene`` at ``density`` pulses per m² (small scenes; see :func:`iter_samples`)."""
    parts = list(iter_samples(scene, density=density, seed=seed))
    cols = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    return _to_cloud(scene, cols)


def iter_samples(scene: Scene, *, density: float, seed: int = 0) -> Iterator[dict[str, NDArray]]:
    """Returns block by block (250 m), each block from its own seeded stream."""
    if not (MIN_DENSITY <= density <= MAX_DENSITY):
        raise InputError(f"density must be {MIN_DENSITY}..{MAX_DENSITY} pulses/m², got {density}")
    for i, j, bounds in blocks(scene):
        yield sample_block(scene, bounds, density=density, rng=np.random.default_rng([seed, i, j]))


def _to_cloud(scene: Scene, cols: dict[str, NDArray]) -> PointCloud:
    return PointCloud(
        xyz=np.column_stack([cols["x"], cols["y"], cols["z"]]),
        classification=cols["cls"].astype(np.uint8),
        return_number=cols["rn"].astype(np.uint8),
        number_of_returns=cols["nr"].astype(np.uint8),
        crs=as_crs(scene.crs),
        source=f"synthetic scene seed {scene.seed}",
    )
