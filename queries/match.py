"""Find objects in a stored survey with a feature filter."""

from __future__ import annotations

import numpy as np
import shapely
from numpy.typing import NDArray

from queries.centreline import centrelines, elongation
from queries.filters import (
    BREAK_LINES,
    Filter,
    Match,
    builtin_filters,
    candidates,
    components,
    tile_lines,
)
from queries.profile import Nodes, form_width
from queries.relief import tile_relief
from queries.shoulder import shoulders
from tdb.database import Database
from tdb.errors import FilterError
from tdb.options import Measure
from tdb.tiles import NodeLattice, node_lattice

REACH_TILES = 2  # the terrain beside a tile is read this many tiles away from its extreme node
LINK_TILES = 3.0  # extreme nodes of touching tiles lie at most 2√2 tiles apart
TILE_SHARE = 0.5  # a tile joins an object when its own relief reaches this share of min_measure


def _broad(
    lattice: NodeLattice, geoms: list[shapely.Geometry], shoulder: NDArray[np.float64], flt: Filter
) -> NDArray[np.bool_]:
    """Per match, whether a shoulder that reads narrow is overruled by cross-sections at least
    ``flt.broad_width`` wide. Only those matches are measured: the fits cost time."""
    broad = np.zeros(len(geoms), bool)
    bound = flt.min_shoulder if flt.min_shoulder is not None else flt.max_shoulder
    if flt.broad_width is None or bound is None:
        return broad
    with np.errstate(invalid="ignore"):
        narrow = np.flatnonzero(shoulder <= bound)
    if len(narrow):
        nodes = Nodes.of(*lattice.points())
        for k in narrow:
            broad[k] = form_width(geoms[k], nodes, measure=flt.measure) >= flt.broad_width
    return broad


def resolve(name_or_filter: str | Filter) -> Filter:
    if isinstance(name_or_filter, Filter):
        return name_or_filter
    known = builtin_filters()
    if name_or_filter not in known:
        raise FilterError(f"no filter {name_or_filter!r}; built in: {', '.join(sorted(known))}")
    return known[name_or_filter]


def find(
    db: Database,
    version: str,
    name_or_filter: str | Filter,
    *,
    level: int | None = None,
    bbox: tuple[float, float, float, float] | None = None,
) -> list[Match]:
    """Objects matching a filter at ``level`` (default: the filter's own) inside ``bbox``.

    Tiles of the filter's features join an object only where they stand out of the
    terrain on both sides (:func:`queries.relief.two_sided_relief`) by at least half
    the filter's ``min_measure``; an object's measure is the median over its tiles.
    """
    flt = resolve(name_or_filter)
    lv = level or flt.level
    xg, yg, code = db.tiles(version, level=lv, bbox=bbox)
    evidence = candidates(xg, yg, code, flt, lv)
    if not np.logical_or(*evidence).any():
        return []
    grow = REACH_TILES * lv + lv
    px, py, pz, _ = db.points(
        version,
        level=lv,
        bbox=None if bbox is None else (bbox[0] - grow, bbox[1] - grow, bbox[2] + grow, bbox[3] + grow),
        ordered=False,
    )
    return match_tiles(xg, yg, code, node_lattice(px, py, pz, lv), flt, level=lv, evidence=evidence)


def match_tiles(
    xg: NDArray[np.int64],
    yg: NDArray[np.int64],
    code: NDArray[np.uint8],
    lattice: NodeLattice,
    flt: Filter,
    *,
    level: int,
    shapes: bool = True,
    evidence: tuple[NDArray[np.bool_], NDArray[np.bool_]] | None = None,
) -> list[Match]:
    """The objects ``flt`` finds among the tiles, with ``lattice`` holding the stored points
    around them. Without ``shapes`` the matches
    carry their tiles and measure only (empty geometry, length NaN, no shoulder test: a
    shoulder needs the centre line): what typing needs, where a ridge and a wall are one form.
    ``evidence`` is :func:`queries.filters.candidates` of these tiles, where the caller has it."""
    lv = level
    own, facing = evidence if evidence is not None else candidates(xg, yg, code, flt, lv)
    cand = np.flatnonzero(own | facing)
    if len(cand) == 0:
        return []
    # A pair of facing planes is weaker evidence than a valley in a tile: it must stand out by
    # the filter's whole measure, not a share of it, or gentle hollows chain distinct forms
    share = np.where(own[cand], TILE_SHARE, 1.0)
    ex, ey, relief = tile_relief(
        lattice,
        xg[cand],
        yg[cand],
        measure=flt.measure,
        reach=REACH_TILES * lv,
        along=BREAK_LINES[code[cand]],
        around=flt.around,
    )
    with np.errstate(invalid="ignore"):
        # NaN (terrain beside unknown) is kept, but a closed form must be seen all round
        ok = relief >= share * flt.min_measure if flt.around else ~(relief < share * flt.min_measure)
    keep, relief, ex, ey = cand[ok], relief[ok], ex[ok], ey[ok]
    xg, yg, code = xg[keep], yg[keep], code[keep]
    groups = components(xg, yg, code, flt, lv, accept=np.ones(len(keep), bool))
    found: list[tuple[NDArray[np.intp], float]] = []
    for g in groups:
        if not np.isfinite(relief[g]).any():
            measure = float("nan")
        else:  # a closed form stands out most at its top (bottom); a line is measured along it
            measure = float(np.nanmax(relief[g]) if flt.around else np.nanmedian(relief[g]))
        if measure < flt.min_measure:  # NaN (no relief measured) is kept
            continue
        if flt.linear and elongation(ex[g], ey[g], level=lv) < flt.min_elongation:
            continue
        found.append((g, measure))
    if not shapes:
        return [Match(flt.name, lv, keep[g], shapely.GeometryCollection(), float("nan"), m) for g, m in found]
    if flt.linear and flt.measure is not Measure.STEP:
        owner = np.repeat(np.arange(len(found)), [len(g) for g, _ in found])
        tiles = np.concatenate([g for g, _ in found]) if found else np.zeros(0, np.intp)
        link = (LINK_TILES + flt.gap) * lv
        geoms = centrelines(ex[tiles], ey[tiles], owner, link=link, count=len(found))
    else:  # a step has no extreme line; polygons come from the tiles
        geoms = [shapely.LineString()] * len(found)
    shoulder = np.full(len(found), np.nan)
    if (
        flt.linear
        and flt.measure is not Measure.STEP
        and (flt.min_shoulder is not None or flt.max_shoulder is not None)
    ):
        shoulder = shoulders(lattice, geoms, np.array([m for _, m in found]), measure=flt.measure)
    broad = _broad(lattice, geoms, shoulder, flt)
    out = []
    for (g, measure), geom, sh, wide in zip(found, geoms, shoulder, broad):
        # an unmeasured shoulder passes a least one and fails a largest one: a form is a ridge
        # (or a ditch) unless it is shown to be narrow
        if flt.min_shoulder is not None and sh < flt.min_shoulder and not wide:
            continue
        if flt.max_shoulder is not None and (not sh <= flt.max_shoulder or wide):
            continue
        if flt.linear:
            if geom.is_empty:  # no extreme line: follow the break lines
                lines = [line for line in tile_lines(xg[g], yg[g], code[g], lv) if line is not None]
                geom = shapely.line_merge(shapely.union_all(lines))
            if geom.is_empty:  # planes falling to one corner: a hollow, no line
                continue
            length = float(geom.length)
        else:
            # tiles never overlap: a coverage union is exact and much faster than a general one
            geom = shapely.coverage_union_all(shapely.box(xg[g], yg[g], xg[g] + lv, yg[g] + lv))
            length = 0.0
        out.append(Match(flt.name, lv, keep[g], geom, length, measure, float(sh)))
    return out
