"""The exact bare-earth height of a synthetic scene at any plan position."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ingest.synth.forms import Feature
from ingest.synth.geometry import distance_to_polyline, in_bbox, project_on_polyline
from ingest.synth.scene import Relief, Scene


def relief_height(relief: Relief, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
    """Hills plus the escarpment, without terrain features."""
    z = np.full(x.shape, relief.base)
    for amplitude, kx, ky, phase in relief.waves:
        z += amplitude * np.sin(kx * x + ky * y + phase)
    nx, ny = relief.scarp_normal
    px, py = relief.scarp_point
    d = (x - px) * nx + (y - py) * ny
    z += relief.scarp_height * 0.5 * (1 + np.tanh(d / (relief.scarp_width / 2)))
    return z


def profile(
    feature: Feature, d: NDArray[np.float64], size: NDArray[np.float64] | float, width: NDArray[np.float64] | float
) -> NDArray[np.float64]:
    """Magnitude (≥ 0) of a feature of ``size`` and full ``width`` at plan distance ``d`` from its axis."""
    half = np.asarray(width) / 2
    u = np.clip(d / half, 0, 1)
    if feature.kind in ("embankment", "road"):
        slope = float(feature.profile.split("slope=")[1])
        return size * np.clip((half - d) / slope, 0, 1)
    if feature.kind in ("pit", "mound", "valley", "spur"):
        return size * 0.5 * (1 + np.cos(np.pi * u))  # smooth bowl, dome or natural hollow
    if feature.profile == "U":
        return size * (1 - u**4)
    return size * (1 - u)


def _edge(feature: Feature, xs: NDArray[np.float64], ys: NDArray[np.float64]) -> NDArray[np.float64]:
    """A field edge (a straight line): a bank rising to the left of the line, the field above it
    falling back to the lower field's level over ``terrace`` metres; beyond the ends the step
    fades out over 10 m."""
    (ax, ay), (bx, by) = np.asarray(feature.geometry.coords)[[0, -1]]
    length = float(np.hypot(bx - ax, by - ay))
    ux, uy = (bx - ax) / length, (by - ay) / length
    t = (xs - ax) * ux + (ys - ay) * uy
    s = (ys - ay) * ux - (xs - ax) * uy  # across the line, positive on its left (the raised side)
    half = feature.width / 2
    rise = np.clip((s + half) / feature.width, 0, 1)
    back = np.clip(1 - (s - half) / feature.terrace, 0, 1)
    fade = np.clip(1 - np.maximum(-t, t - length) / 10, 0, 1)
    return feature.size * np.where(s <= half, rise, back) * fade


def feature_offset(feature: Feature, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
    """Signed height a feature adds at (x, y): negative for ditches, pits and valleys."""
    out = np.zeros(x.shape)
    near = in_bbox(x, y, feature.geometry.bounds, margin=feature.reach)
    if not near.any():
        return out
    xs, ys = x[near], y[near]
    if feature.kind == "edge":
        out[near] = _edge(feature, xs, ys)
        return out
    size: NDArray[np.float64] | float = feature.size
    width: NDArray[np.float64] | float = feature.width
    if feature.geometry.geom_type == "Point":
        d = np.hypot(xs - feature.geometry.x, ys - feature.geometry.y)
    elif feature.tapers:
        d, at, _ = project_on_polyline(xs, ys, np.asarray(feature.geometry.coords))
        size, width = feature.along(at)
    else:
        d = distance_to_polyline(xs, ys, np.asarray(feature.geometry.coords))
    out[near] = feature.sign * profile(feature, d, size, width)
    return out


def ground_height(scene: Scene, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
    """Bare-earth height at plan positions (x, y) in scene coordinates.

    Cuts (ditches, pits) take the deepest cut where they meet, so joined
    ditches merge; fills (ridges, walls, embankments, mounds) take the highest.
    """
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    z = relief_height(scene.relief, x, y)
    cut = np.zeros(x.shape)
    fill = np.zeros(x.shape)
    for feature in scene.features:
        offset = feature_offset(feature, x, y)
        np.minimum(cut, offset, out=cut)
        np.maximum(fill, offset, out=fill)
    return z + cut + fill


def ground_grid(
    scene: Scene, *, resolution: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The bare earth on a regular grid of cell centres: (x centres, y centres, z[row, col]).

    Rows run north to south, as in a raster.
    """
    x0, y0, x1, y1 = scene.bounds
    xs = np.arange(x0 + resolution / 2, x1, resolution)
    ys = np.arange(y1 - resolution / 2, y0, -resolution)
    gx, gy = np.meshgrid(xs, ys)
    return xs, ys, ground_height(scene, gx.ravel(), gy.ravel()).reshape(gx.shape)
