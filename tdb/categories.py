"""The 115 symbolic tile categories of Elmqvist et al. (§3.1) and their canonical templates.

Sub-parts of a tile (the paper's Figure 10), numbered as on a keypad seen from above::

    6 7 8      NW  N  NE
    3 4 5  =   W   C  E
    0 1 2      SW  S  SE

Corners are 0, 2, 6, 8; edges 1, 3, 5, 7; the interior 4. A break line runs
between the middles of two boundary sub-parts; the 16 distinct divisions are the
2 diagonals, the 2 mid-lines, the 8 lines from a corner to a non-adjacent edge
and the 4 lines joining adjacent edges. Each division takes 6 plane
combinations (ridge, valley, and a flat plane beside one rising or falling away
from the line, on either side): 96. With the flat tile and the single plane in
8 directions (9) and a peak or pit in an edge sub-part or the interior (10):
115. Code 255 means no data.

Codes are stable: 0 flat; 1–8 one plane rising towards N, NE, E, SE, S, SW, W,
NW; 9 + 6·division + combination for the two-plane forms; 105 + 2·place +
(0 peak, 1 pit) for extreme points, place in (S, W, E, N, interior).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import numpy as np
from numpy.typing import NDArray

from tdb.errors import InputError

NO_DATA = 255
COUNT = 115
SUBPART_NAMES = ("SW", "S", "SE", "W", "C", "E", "NW", "N", "NE")
SUBPART_UV = np.array([[0, 0], [0.5, 0], [1, 0], [0, 0.5], [0.5, 0.5], [1, 0.5], [0, 1], [0.5, 1], [1, 1]])
DIRECTIONS = ("N", "NE", "E", "SE", "S", "SW", "W", "NW")  # inclination codes 1..8
DIRECTION_VECTORS = np.array([[0, 1], [1, 1], [1, 0], [1, -1], [0, -1], [-1, -1], [-1, 0], [-1, 1]]) / np.array(
    [[1], [np.sqrt(2)], [1], [np.sqrt(2)], [1], [np.sqrt(2)], [1], [np.sqrt(2)]]
)

# The 16 divisions as (start, end) sub-parts.
DIVISIONS: tuple[tuple[int, int], ...] = (
    (0, 8), (2, 6),  # diagonals
    (1, 7), (3, 5),  # mid-lines
    (0, 7), (0, 5), (2, 7), (2, 3), (8, 1), (8, 3), (6, 1), (6, 5),  # corner to far edge
    (1, 3), (1, 5), (7, 3), (7, 5),  # adjacent edges
)  # fmt: skip

# Feature sub-indicator.
NONE, RIDGE, VALLEY, STEP_UP, STEP_DOWN, PEAK, PIT = range(7)
FEATURE_NAMES = ("none", "ridge", "valley", "flat beside rising plane", "flat beside falling plane", "peak", "pit")
# Plane combinations per division: (feature, flat side) with side +1 = right of start→end, -1 = left.
COMBINATIONS = ((RIDGE, 0), (VALLEY, 0), (STEP_UP, -1), (STEP_DOWN, -1), (STEP_UP, +1), (STEP_DOWN, +1))
EXTREME_PLACES = (1, 3, 5, 7, 4)  # S, W, E, N, interior


@dataclass(frozen=True)
class Category:
    """One category and its sub-indicators.

    inclination: 0 none, 1–8 the representative rising direction (see DIRECTIONS).
    feature: NONE, RIDGE, VALLEY, STEP_UP, STEP_DOWN, PEAK or PIT.
    orientation: (start, end) sub-parts of the break line, or (place, place) for
    an extreme point, or None. For steps the flat plane lies on the ``flat_side``
    (+1 right, -1 left) of start→end.
    """

    code: int
    inclination: int
    feature: int
    orientation: tuple[int, int] | None
    flat_side: int = 0

    @property
    def description(self) -> str:
        if self.code == 0:
            return "flat"
        if self.feature == NONE:
            return f"plane rising {DIRECTIONS[self.inclination - 1]}"
        assert self.orientation is not None
        a, b = (SUBPART_NAMES[i] for i in self.orientation)
        if self.feature in (PEAK, PIT):
            return f"{FEATURE_NAMES[self.feature]} at {a}"
        text = f"{FEATURE_NAMES[self.feature]} along {a}–{b}"
        if self.flat_side:
            text += f", flat on the {'right' if self.flat_side > 0 else 'left'}"
        return text


def _signed_distance(uv: NDArray[np.float64], a: int, b: int) -> NDArray[np.float64]:
    """Signed plan distance of points to the line through sub-parts a→b (+ on the right)."""
    p, q = SUBPART_UV[a], SUBPART_UV[b]
    d = (q - p) / np.linalg.norm(q - p)
    rel = uv - p
    return rel[:, 0] * d[1] - rel[:, 1] * d[0]


def _nearest_direction(vec: NDArray[np.float64]) -> int:
    return int(np.argmax(DIRECTION_VECTORS @ (vec / np.linalg.norm(vec)))) + 1


@cache
def all_categories() -> tuple[Category, ...]:
    """All 115 categories, index = code."""
    cats = [Category(0, 0, NONE, None)]
    cats += [Category(i, i, NONE, None) for i in range(1, 9)]
    for div, (a, b) in enumerate(DIVISIONS):
        p, q = SUBPART_UV[a], SUBPART_UV[b]
        right = np.array([(q - p)[1], -(q - p)[0]])  # unit normal pointing to the right side
        for combo, (feature, side) in enumerate(COMBINATIONS):
            # Representative inclination: the rising direction of the inclined plane
            # (the right-hand one for ridges and valleys).
            if feature == RIDGE:
                rising = -right
            elif feature == VALLEY:
                rising = right
            else:
                inclined_side = -side
                away = right * inclined_side
                rising = away if feature == STEP_UP else -away
            cats.append(Category(9 + div * 6 + combo, _nearest_direction(rising), feature, (a, b), side))
    for k, place in enumerate(EXTREME_PLACES):
        for j, feature in enumerate((PEAK, PIT)):
            cats.append(Category(105 + 2 * k + j, 0, feature, (place, place)))
    assert len(cats) == COUNT and all(c.code == i for i, c in enumerate(cats))
    return tuple(cats)


def by_code(attribute: str, *, missing: int = -1) -> NDArray[np.int64]:
    """(256,) one sub-indicator (``"feature"``, ``"inclination"``) of every uint8 code, ``missing``
    for codes that are no category (no data), so that ``by_code(...)[codes]`` is one gather."""
    cats = all_categories()
    return np.array([getattr(c, attribute) for c in cats] + [missing] * (256 - len(cats)), np.int64)


def subgrid_uv(n: int) -> NDArray[np.float64]:
    """(n*n, 2) sub-grid node positions in the unit tile, row-major from the south-west."""
    t = np.linspace(0, 1, n)
    u, v = np.meshgrid(t, t)
    return np.column_stack([u.ravel(), v.ravel()])


def _shape(cat: Category, uv: NDArray[np.float64]) -> NDArray[np.float64]:
    if cat.code == 0:
        return np.zeros(len(uv))
    if cat.feature == NONE:
        return uv @ DIRECTION_VECTORS[cat.inclination - 1]
    assert cat.orientation is not None
    a, b = cat.orientation
    if cat.feature in (PEAK, PIT):
        d = np.linalg.norm(uv - SUBPART_UV[a], axis=1)
        return -d if cat.feature == PEAK else d
    s = _signed_distance(uv, a, b)
    if cat.feature == RIDGE:
        return -np.abs(s)
    if cat.feature == VALLEY:
        return np.abs(s)
    inclined = np.maximum(-cat.flat_side * s, 0.0)  # distance into the inclined side
    return inclined if cat.feature == STEP_UP else -inclined


MAX_SUBGRID = 65  # nodes per side: a 16 m tile at 0.25 m


def check_subgrid(n: int) -> int:
    """``n`` nodes per tile side, or an :class:`InputError` where templates cannot have that many."""
    if n < 5:
        raise InputError(
            f"a sub-grid of {n} nodes per side is too small: corners, edge middles and an interior need 5"
        )
    if n > MAX_SUBGRID:
        raise InputError(f"a sub-grid of {n} nodes per side is more than the {MAX_SUBGRID} a tile is drawn with")
    return n


@cache
def templates(n: int = 5) -> NDArray[np.float64]:
    """Canonical templates (115, n*n) normalised to [0, 1]; row 0 (flat) is all zeros."""
    check_subgrid(n)
    uv = subgrid_uv(n)
    out = np.zeros((COUNT, n * n))
    for cat in all_categories()[1:]:
        z = _shape(cat, uv)
        out[cat.code] = (z - z.min()) / (z.max() - z.min())
    out.flags.writeable = False
    return out


@cache
def feature_nodes(n: int = 5) -> NDArray[np.bool_]:
    """(115, n*n) mask of the sub-grid nodes on each category's feature (break line or extreme point)."""
    uv = subgrid_uv(n)
    half = 0.5 / (n - 1)
    out = np.zeros((COUNT, n * n), bool)
    for cat in all_categories():
        if cat.orientation is None:
            continue
        a, b = cat.orientation
        if a == b:
            out[cat.code, np.argmin(np.linalg.norm(uv - SUBPART_UV[a], axis=1))] = True
        else:
            p, q = SUBPART_UV[a], SUBPART_UV[b]
            t = np.clip(((uv - p) @ (q - p)) / ((q - p) @ (q - p)), 0, 1)
            out[cat.code] = np.linalg.norm(uv - (p + t[:, None] * (q - p)), axis=1) <= half + 1e-9
    out.flags.writeable = False
    return out
