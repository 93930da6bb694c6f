"""Footprint outlines fitted wall by wall.

A footprint drawn where the nearest return is a roof's follows the returns, so each wall's
edge zigzags by about a pulse spacing. Buildings stand on few directions: most walls are
parallel or square to the building's main direction. The outline is simplified, each stretch
that stays within ``resolution`` of a line square to that direction becomes that line, placed at
the median of the outline it replaces (every return along the wall votes), and the rest keep a
line fitted to their stretch. Corners are where the lines meet. A wall is squared only where
squaring moves it by no more than the outline's own zigzag, so a building whose walls are not
square keeps its own angles.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import NDArray

from tdb.median import weighted_quantile

ALONG, ACROSS, FREE = 0, 1, 2  # a stretch parallel to the main direction, square to it, or neither
MIN_SINE = 0.5  # lines meeting at under 30° are joined by a step, not intersected: a spike is no corner
ANGLE_STEP = 0.5  # degrees between the directions tried
SUB = 4  # bins of resolution / 8 in the sliding window: half a resolution across a direction
MIN_CELLS = 4  # a footprint narrower than this many resolutions has no wall a fit could find
FAR = 1.5  # resolutions: an intersection this far from the stretches' meeting point is a step


@dataclass(frozen=True)
class _Stretch:
    kind: int
    offset: float  # ALONG: the median v; ACROSS: the median u; FREE: unused
    point: NDArray[np.float64]  # FREE: a point of the fitted line
    direction: NDArray[np.float64]  # FREE: the fitted line's unit direction
    start: NDArray[np.float64]  # the outline's vertex where the stretch begins
    vertices: NDArray[np.float64]  # the outline's vertices along the stretch, its ends included


def main_direction(polygon: shapely.Polygon, *, resolution: float) -> float:
    """The angle (radians, in [0, π/2)) at which the outline's length piles up most on few lines
    square to each other: walls along a direction gather within ``resolution / 2`` across it,
    where a zigzag spreads."""
    ring = np.asarray(polygon.exterior.coords)
    mid = (ring[1:] + ring[:-1]) / 2
    mid -= mid.mean(axis=0)
    length = np.hypot(*np.diff(ring, axis=0).T)
    angles = np.deg2rad(np.arange(0.0, 90.0, ANGLE_STEP))
    c, s = np.cos(angles), np.sin(angles)
    score = np.zeros(len(angles))
    for across in (mid[:, :1] * -s + mid[:, 1:] * c, mid[:, :1] * c + mid[:, 1:] * s):
        # fine bins summed over a sliding half-resolution window: a wall's pile does not split
        # where a bin's edge happens to fall
        bins = np.floor(across / (resolution / 8)).astype(np.int64)
        bins -= bins.min(axis=0)
        width = int(bins.max()) + 1
        flat = (bins + np.arange(len(angles)) * width).ravel()
        piles = np.bincount(flat, weights=np.repeat(length, len(angles)), minlength=width * len(angles))
        cum = np.cumsum(np.pad(piles.reshape(len(angles), width), ((0, 0), (SUB, SUB))), axis=1)
        score += ((cum[:, SUB:] - cum[:, :-SUB]) ** 2).sum(axis=1)
    return float(angles[int(np.argmax(score))])


def fit_walls(geometry: shapely.Geometry, *, resolution: float) -> shapely.Geometry | None:
    """``geometry`` (a polygon or multipolygon) with its rings fitted wall by wall, ``resolution``
    (m) the least step of a wall the outline can show; None where no fit keeps within half of
    ``resolution`` of ``geometry``, on average along its outline. Rings too small to hold three
    walls are kept simplified, or left out (holes, and parts under a square of ``resolution``)."""
    polygons = list(getattr(geometry, "geoms", [geometry]))
    largest = max(polygons, key=lambda p: p.area)
    if _width(largest) < MIN_CELLS * resolution:
        return None
    piled = main_direction(largest, resolution=resolution)
    pooled = _refined(np.asarray(largest.exterior.coords), piled, resolution)
    fits = [f for f in (_fitted(polygons, a, resolution) for a in (piled, pooled)) if f is not None]
    if not fits:
        return None
    # the direction whose walls keep nearer the drawn outline: the outlines' area apart
    apart, out = min(((f.symmetric_difference(geometry).area, f) for f in fits), key=lambda pair: pair[0])
    # the outlines' mean distance apart, measured along the fitted walls
    return None if apart > resolution / 2 * out.length else out


def _fitted(polygons: list[shapely.Polygon], angle: float, resolution: float) -> shapely.Geometry | None:
    """The ``polygons`` fitted wall by wall in the frame of ``angle`` (None where the fit is no
    valid geometry)."""
    fitted = []
    for polygon in polygons:
        shell = _fit_ring(np.asarray(polygon.exterior.coords), angle, resolution)
        if shell is None:
            if polygon.area >= resolution**2:
                fitted.append(polygon.simplify(resolution / 2))
            continue
        holes = [_fit_ring(np.asarray(r.coords), angle, resolution) for r in polygon.interiors]
        walled = shapely.Polygon(shell, [h for h in holes if h is not None])
        fitted.append(walled if walled.is_valid else polygon.simplify(resolution / 2))
    out = shapely.union_all(fitted)
    return None if out.is_empty or not out.is_valid else out


def _refined(ring: NDArray[np.float64], angle: float, resolution: float) -> float:
    """``angle`` turned to the direction the ring's walls run along together: each wall's edges
    about their own centre (those square to the main direction turned a right angle), their
    pooled principal axis, each edge weighed by its length. Every edge of every wall votes, where
    the piles of :func:`main_direction` see directions half a degree apart through a zigzag; but
    a poor draw's stretches can lead it astray too, so the fit keeps whichever of the two
    directions keeps its walls nearer the outline (:func:`fit_walls`)."""
    c, s = np.cos(angle), np.sin(angle)
    uv = (ring - ring[:-1].mean(axis=0)) @ np.array([[c, -s], [s, c]])
    scatter = np.zeros((2, 2))
    for stretch in _stretches(uv, resolution):
        if stretch.kind == FREE:
            continue
        v = stretch.vertices if stretch.kind == ALONG else stretch.vertices[:, ::-1] * np.array([1.0, -1.0])
        mid, length = (v[1:] + v[:-1]) / 2, np.hypot(*np.diff(v, axis=0).T)
        d = mid - np.average(mid, axis=0, weights=length)
        scatter += (d * length[:, None]).T @ d
    if not scatter.any():
        return angle
    _, vectors = np.linalg.eigh(scatter)
    u, w = vectors[:, -1] * np.sign(vectors[0, -1] or 1.0)
    return angle + float(np.arctan2(w, u))


def _width(polygon: shapely.Polygon) -> float:
    """The shorter side of the least-area rectangle around ``polygon``."""
    corners = np.asarray(shapely.minimum_rotated_rectangle(polygon).exterior.coords)
    return float(min(np.hypot(*(corners[1] - corners[0])), np.hypot(*(corners[2] - corners[1]))))


def _fit_ring(ring: NDArray[np.float64], angle: float, resolution: float) -> NDArray[np.float64] | None:
    """The ring's walls as lines in the frame of ``angle``, joined at their meeting points."""
    c, s = np.cos(angle), np.sin(angle)
    centre = ring[:-1].mean(axis=0)
    uv = (ring - centre) @ np.array([[c, -s], [s, c]])
    stretches = _stretches(uv, resolution)
    if len(stretches) < 3:
        return None
    corners = _corners(stretches, resolution)
    if len(corners) < 3:
        return None
    # a corner far from the outline is lines crossing where no wall is: a spike or a chevron
    if np.max(shapely.distance(shapely.points(corners), shapely.LinearRing(uv))) > FAR * resolution:
        return None
    xy = np.asarray(corners) @ np.array([[c, s], [-s, c]]) + centre
    return np.vstack([xy, xy[:1]])


def _stretches(uv: NDArray[np.float64], resolution: float) -> list[_Stretch]:
    """The simplified ring's edges as stretches of the outline: neighbours on one line merged,
    and stretches shorter than ``resolution`` dropped into their neighbours."""
    key = _simplified(uv, resolution)
    mid = (uv[1:] + uv[:-1]) / 2
    length = np.hypot(*np.diff(uv, axis=0).T)
    spans = [np.arange(a, b) for a, b in itertools.pairwise(key)]
    # A span is a run of the ring's edges, known by its first edge and its length; each join
    # makes one new span, so each span's kind and offset are worked out once.
    known: dict[tuple[int, int], tuple[int, float]] = {}

    def kind_offset(span: NDArray[np.intp]) -> tuple[int, float]:
        tag = (int(span[0]), len(span))
        if tag not in known:
            kind = _kind(mid[span], length[span], resolution)
            known[tag] = (kind, _offset(mid, length, span, kind))
        return known[tag]

    while len(spans) > 3:
        kinds, offsets = (list(a) for a in zip(*(kind_offset(i) for i in spans), strict=True))
        n = len(spans)
        same = [
            kinds[k] == kinds[(k + 1) % n] != FREE and abs(offsets[k] - offsets[(k + 1) % n]) < resolution
            for k in range(n)
        ]
        if any(same):
            k = same.index(True)
            _join(spans, k, (k + 1) % n)
            continue
        chord = [float(np.hypot(*(uv[i[-1] + 1] - uv[i[0]]))) for i in spans]
        k = int(np.argmin(chord))
        if chord[k] >= resolution:
            break
        before, after = (k - 1) % n, (k + 1) % n
        if kinds[before] == kinds[after] != FREE and abs(offsets[before] - offsets[after]) < resolution:
            _join(spans, before, k)
        else:  # a bevel: its neighbours' lines meet without it
            first = chord[before] < chord[after]
            _join(spans, before if first else k, k if first else after)
    _drop_cut_corners(spans, uv, kind_offset, resolution)
    out = []
    for span in spans:
        kind, offset = kind_offset(span)
        point, direction = _line(uv[np.union1d(span, span + 1)])
        out.append(_Stretch(kind, offset, point, direction, uv[span[0]], uv[np.r_[span, span[-1] + 1]]))
    return out


def _drop_cut_corners(
    spans: list[NDArray[np.intp]],
    uv: NDArray[np.float64],
    kind_offset: Callable[[NDArray[np.intp]], tuple[int, float]],
    resolution: float,
) -> None:
    """Join into the next stretch each free stretch between two walls square to each other whose
    outline keeps within ``resolution`` of those walls' lines: the simplification cut a corner the
    outline turns (its vertex lay under ``resolution`` from the chord), and the walls meet there."""
    k = 0
    while len(spans) > 3 and k < len(spans):
        n = len(spans)
        before, after = kind_offset(spans[(k - 1) % n]), kind_offset(spans[(k + 1) % n])
        kind = kind_offset(spans[k])[0]
        if kind == FREE and {before[0], after[0]} == {ALONG, ACROSS}:
            along, across = (before, after) if before[0] == ALONG else (after, before)
            ring = uv[np.union1d(spans[k], spans[k] + 1)]
            off = np.minimum(np.abs(ring[:, 1] - along[1]), np.abs(ring[:, 0] - across[1]))
            if off.max() <= resolution:
                _join(spans, k, (k + 1) % n)
                k = 0
                continue
        k += 1


def _join(spans: list[NDArray[np.intp]], k: int, j: int) -> None:
    """Stretch ``j`` (the one after ``k`` around the ring) joins stretch ``k``."""
    spans[k] = np.concatenate([spans[k], spans[j]])
    del spans[j]
    if j < k:  # the ring's first stretch joined its last: the last now starts the ring
        spans.insert(0, spans.pop())


def _kind(mid: NDArray[np.float64], length: NDArray[np.float64], resolution: float) -> int:
    """ALONG or ACROSS where most of the stretch lies within ``resolution`` of such a line."""
    spread = [_spread(mid[:, 1], length), _spread(mid[:, 0], length)]
    best = int(np.argmin(spread))
    return best if spread[best] <= resolution else FREE


def _spread(values: NDArray[np.float64], weight: NDArray[np.float64]) -> float:
    """The weighted 80th percentile of the departures from the weighted median."""
    return weighted_quantile(np.abs(values - weighted_quantile(values, weight, 0.5)), weight, 0.8)


def _offset(mid: NDArray[np.float64], length: NDArray[np.float64], span: NDArray[np.intp], kind: int) -> float:
    if kind == FREE:
        return 0.0
    return weighted_quantile(mid[span, 1 - kind], length[span], 0.5)


def _line(points: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The total-least-squares line through a stretch's vertices."""
    point = points.mean(axis=0)
    d = points - point
    _, vectors = np.linalg.eigh(d.T @ d)
    return point, vectors[:, -1]


def _as_line(s: _Stretch) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    if s.kind == ALONG:
        return np.array([0.0, s.offset]), np.array([1.0, 0.0])
    if s.kind == ACROSS:
        return np.array([s.offset, 0.0]), np.array([0.0, 1.0])
    return s.point, s.direction


def _corners(stretches: list[_Stretch], resolution: float) -> list[NDArray[np.float64]]:
    """Where each stretch's line meets the next one's: their intersection, or a step at the
    outline's vertex between them where they are parallel or meet far from the outline of both.
    Far from the outline, not from the vertex between them: a stretch may begin with a cut corner
    joined to it, the outline turning well before that vertex."""
    out = []
    for k, a in enumerate(stretches):
        b = stretches[(k + 1) % len(stretches)]
        pa, da = _as_line(a)
        pb, db = _as_line(b)
        sine = da[0] * db[1] - da[1] * db[0]
        joint = b.start
        if abs(sine) >= MIN_SINE:
            t = ((pb - pa)[0] * db[1] - (pb - pa)[1] * db[0]) / sine
            corner = pa + t * da
            near = np.hypot(*(np.vstack([a.vertices, b.vertices]) - corner).T).min()
            if near <= FAR * resolution:
                out.append(corner)
                continue
        out.append(pa + ((joint - pa) @ da) * da)
        out.append(pb + ((joint - pb) @ db) * db)
    return out


def _simplified(ring: NDArray[np.float64], resolution: float) -> NDArray[np.intp]:
    """Indices of the vertices Douglas–Peucker keeps of a closed ring, first and last included."""
    n = len(ring) - 1
    far = int(np.argmax(np.hypot(*(ring[:n] - ring[0]).T)))
    keep = np.zeros(n + 1, bool)
    keep[[0, far, n]] = True
    stack = [(0, far), (far, n)]
    while stack:
        a, b = stack.pop()
        if b - a < 2:
            continue
        p, q = ring[a], ring[b]
        d = q - p
        norm = np.hypot(*d)
        inner = ring[a + 1 : b] - p
        dist = np.abs(inner[:, 0] * d[1] - inner[:, 1] * d[0]) / norm if norm > 0 else np.hypot(*inner.T)
        i = int(np.argmax(dist))
        if dist[i] > resolution:
            keep[a + 1 + i] = True
            stack += [(a, a + 1 + i), (a + 1 + i, b)]
    return np.flatnonzero(keep)
