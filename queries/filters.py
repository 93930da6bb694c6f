"""Feature filters: objects as patterns over tile categories (the paper's Match step).

A filter is data (JSON validated by ``schemas/filter.schema.json``): the tile
features it accepts, how tiles join (``lines``: only where their break lines
meet at the shared edge middle or corner; ``touch``: where the tiles touch),
whether the match is a line along the break lines or a polygon, its default level.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, fields
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from queries.facing import facing_planes
from tdb.categories import FEATURE_NAMES, SUBPART_UV, all_categories, by_code
from tdb.errors import FilterError
from tdb.options import Measure, parse
from tdb.tiles import LEVELS, TileIndex

# Feature of each uint8 code (-1 for codes that are no category: no data, absent).
FEATURES = by_code("feature")


@cache
def _line_ends() -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """Per code, the break line's end points in tile units, and whether the code has one."""
    start, end, has = np.zeros((256, 2)), np.zeros((256, 2)), np.zeros(256, bool)
    for c in all_categories():
        if c.orientation is not None and c.orientation[0] != c.orientation[1]:
            start[c.code], end[c.code], has[c.code] = (
                SUBPART_UV[c.orientation[0]],
                SUBPART_UV[c.orientation[1]],
                True,
            )
    return start, end, has


def _break_lines() -> NDArray[np.float64]:
    start, end, has = _line_ends()
    d = end - start
    length = np.linalg.norm(d, axis=1, keepdims=True)
    return np.where(has[:, None], d / np.where(has[:, None], length, 1.0), np.nan)


# Unit direction of each code's break line in plan (NaN for codes without one).
BREAK_LINES = _break_lines()


@dataclass(frozen=True)
class Filter:
    """A feature filter: which tile features make up the form, and how its tiles join and are
    measured. The defaults here are the defaults of ``schemas/filter.schema.json``."""

    name: str
    features: frozenset[int]
    linear: bool
    level: int = 2
    min_tiles: int = 1
    measure: Measure = Measure.HEIGHT
    description: str = ""
    join: str = "lines"
    min_measure: float = 0.0
    gap: int = 0
    min_elongation: float = 0.0
    min_shoulder: float | None = None  # queries.shoulder: a ridge's flanks stand, a wall's do not
    max_shoulder: float | None = None
    broad_width: float | None = None  # queries.profile: at least this wide is broad, whatever the shoulder
    max_spread: float | None = None  # queries.match: relief twice as far off, over the relief, at most this
    min_spread: float | None = None  # queries.match: the same, at least this
    max_trend: float | None = None  # queries.profile: the measure's change along a line, over itself, at most
    max_width: float | None = None  # queries.match: the widest a form is (m), where its usual band sees no feet
    notch_width: float | None = None  # queries.match: at most this wide (m), a line passes max_spread
    max_on_mounds: float | None = None  # queries.match: the most of a line that may lie on mounds (a crest)
    max_by_ditches: float | None = None  # queries.match: the most of a line that may lie by deeper ditches (a lip)
    ditch_ratio: float = 1.0  # queries.match: a ditch by a line counts where this many times as deep as it is high
    around: bool = False  # queries.relief: the extreme stands out all round (mound, pit), not across a line
    facing: bool = False  # queries.facing: plane tiles facing each other across an edge join as well


@cache
def _validator() -> Any:
    import jsonschema

    schema = _schema()
    cls = jsonschema.validators.validator_for(schema)
    cls.check_schema(schema)
    return cls(schema)


def _schema() -> dict[str, Any]:
    path = Path(__file__).resolve().parents[1] / "schemas" / "filter.schema.json"
    if not path.exists():  # installed without the source tree
        path = Path(str(resources.files("schemas") / "filter.schema.json"))
    doc: dict[str, Any] = json.loads(path.read_text())
    doc["properties"]["level"]["enum"] = list(LEVELS)  # the pyramid's levels are defined once, in code
    return doc


def parse_filter(doc: dict[str, Any]) -> Filter:
    """Validate a filter document and build the :class:`Filter`.

    Raises
    ------
    FilterError
        If the document does not follow ``schemas/filter.schema.json``.
    """
    from jsonschema.exceptions import best_match

    error = best_match(_validator().iter_errors(doc))
    if error is not None:
        where = "/".join(map(str, error.absolute_path)) or "filter"
        raise FilterError(f"invalid filter ({where}): {error.message}")
    given = {f.name: doc[f.name] for f in fields(Filter) if f.name in doc and f.name != "features"}
    given.setdefault("join", "lines" if doc["linear"] else "touch")
    if "measure" in given:
        given["measure"] = parse(Measure, given["measure"])
    return Filter(features=frozenset(FEATURE_NAMES.index(f) for f in doc["features"]), **given)


def load_filter(path: str | os.PathLike[str]) -> Filter:
    try:
        doc = json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise FilterError(f"{path}: cannot read filter ({exc})") from None
    return parse_filter(doc)


def builtin_filters() -> dict[str, Filter]:
    """The filters shipped in ``queries/filters``, by name (read and validated once per process)."""
    return dict(_builtin_filters())


@cache
def _builtin_filters() -> dict[str, Filter]:
    folder = Path(__file__).resolve().parent / "filters"
    return {f.name: f for f in (load_filter(p) for p in sorted(folder.glob("*.json")))}


@dataclass(frozen=True)
class Match:
    """One matched object: its tiles and geometry (a line for linear filters, else a polygon)."""

    filter: str
    level: int
    tiles: NDArray[np.intp]
    geometry: shapely.Geometry
    length: float
    measure: float
    shoulder: float = float("nan")  # queries.shoulder; NaN where not measured


# For each category, the sub-parts its feature touches on the tile boundary.
def _endpoints() -> list[tuple[int, ...]]:
    out: list[tuple[int, ...]] = []
    for c in all_categories():
        if c.orientation is None:
            out.append(())
        else:
            out.append(tuple(sorted(set(c.orientation))))
    return out


# Neighbour offsets and the sub-part pairs that meet across the shared edge or corner.
LINKS = {
    (1, 0): ((2, 0), (5, 3), (8, 6)),
    (0, 1): ((6, 0), (7, 1), (8, 2)),
    (1, 1): ((8, 0),),
    (1, -1): ((2, 6),),
}


def link_reach(flt: Filter) -> int:
    """How many tiles apart, at most along either axis, two tiles that :func:`components` joins
    directly can lie under ``flt``."""
    offsets = LINKS if flt.join == "lines" else _touching(flt.gap)
    return max(max(abs(dx), abs(dy)) for dx, dy in offsets)


def _touching(gap: int) -> dict[tuple[int, int], tuple[tuple[int, int], ...]]:
    """Offsets (one of each ± pair) of the tiles within ``gap`` tiles of touching."""
    r = gap + 1
    return {(dx, dy): () for dx in range(0, r + 1) for dy in range(-r, r + 1) if dx > 0 or dy > 0}


@cache
def _link_tables() -> dict[tuple[int, int], NDArray[np.bool_]]:
    """Per neighbour offset, whether the break lines of codes (a, b) meet across the shared edge."""
    ends = _endpoints()
    tables = {}
    for offset, pairs in LINKS.items():
        table = np.zeros((256, 256), bool)
        for a, ea in enumerate(ends):
            for b, eb in enumerate(ends):
                table[a, b] = any(p in ea and q in eb for p, q in pairs)
        tables[offset] = table
    return tables


def candidates(
    xg: NDArray[np.int64], yg: NDArray[np.int64], code: NDArray[np.uint8], flt: Filter, level: int
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Tiles that may be part of an object under ``flt``: those of its features, and (weaker
    evidence, only with ``flt.facing``) the other inclined planes that face each other across an
    edge (falling towards each other for a depth, rising for a height)."""
    own = np.isin(FEATURES[code], list(flt.features))
    facing = np.zeros_like(own)
    if flt.facing:
        facing = facing_planes(xg, yg, code, level=level, falling=flt.measure is Measure.DEPTH) & ~own
    return own, facing


def components(
    xg: NDArray[np.int64],
    yg: NDArray[np.int64],
    code: NDArray[np.uint8],
    flt: Filter,
    level: int,
    *,
    accept: NDArray[np.bool_] | None = None,
) -> list[NDArray[np.intp]]:
    """Groups of tile indices forming one object under ``flt``, among the tiles ``accept``
    marks (default: :func:`candidates`)."""
    sel = np.flatnonzero(np.logical_or(*candidates(xg, yg, code, flt, level)) if accept is None else accept)
    if len(sel) == 0:
        return []
    ti, tj = np.asarray(xg)[sel] // level, np.asarray(yg)[sel] // level
    index = TileIndex(ti, tj)
    rows, cols = [], []
    for dx, dy in LINKS if flt.join == "lines" else _touching(flt.gap):
        other = index.find(ti + dx, tj + dy)
        k = np.flatnonzero(other >= 0)
        j = other[k]
        if flt.join == "lines":
            meet = _link_tables()[(dx, dy)][code[sel[k]], code[sel[j]]]
            k, j = k[meet], j[meet]
        rows.append(k)
        cols.append(j)
    r, c = np.concatenate(rows), np.concatenate(cols)
    graph = coo_matrix((np.ones(len(r)), (r, c)), shape=(len(sel), len(sel)))
    _, labels = connected_components(graph, directed=False)
    by_label = np.argsort(labels, kind="stable")
    groups = np.split(sel[by_label], np.flatnonzero(np.diff(labels[by_label])) + 1)
    return [g for g in groups if len(g) >= flt.min_tiles]


def tile_lines(xg: NDArray[np.int64], yg: NDArray[np.int64], code: NDArray[np.uint8], level: int) -> list[Any]:
    """Each tile's break line in world coordinates (None for tiles without one)."""
    start, end, has = _line_ends()
    origin = np.column_stack([xg, yg]).astype(np.float64)
    lines = shapely.linestrings(np.stack([origin + start[code] * level, origin + end[code] * level], axis=1))
    return [line if h else None for line, h in zip(lines, has[code])]
