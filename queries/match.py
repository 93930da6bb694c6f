"""Find objects in a stored survey with a feature filter."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import NDArray

from queries.centreline import branches, centrelines, elongation
from queries.filters import (
    BREAK_LINES,
    Filter,
    Match,
    builtin_filters,
    candidates,
    components,
    tile_lines,
)
from queries.parts import Box, Candidates, batches, clipped, line_batches, part_candidates, parts_for
from queries.profile import (
    BAND,
    MIN_TREND_PIECES,
    PIECE,
    Nodes,
    Stretch,
    height_trend,
    side_of,
    stretches_of,
    width_of,
)
from queries.relief import tile_relief, two_sided_relief
from queries.shoulder import shoulders
from tdb.database import Database
from tdb.errors import FilterError
from tdb.options import Measure
from tdb.progress import Progress, labelled, or_silent
from tdb.tiles import NodeLattice, node_lattice
from tdb.workers import on_database

REACH_TILES = 2  # the terrain beside a tile is read this many tiles away from its extreme node
LINK_TILES = 3.0  # extreme nodes of touching tiles lie at most 2√2 tiles apart
TILE_SHARE = 0.5  # a tile joins an object when its own relief reaches this share of min_measure
WIDE = 2  # the band of a form's second trend reading, in usual bands (_steady_along)
WIDTH_STEP = 0.05  # m: a fitted width this close to the band's limit reads at the limit
ARM = PIECE  # m: an arm of a group is a line of its own where it runs at least this far from the junction
SPREAD_READ = 2  # a form's spread: its relief read this many times farther off than its relief (max_spread)
NEAR_MARGIN = 4  # tiles beyond a form's reach that the forms near a line are matched with (_forms_near)
READ_MARGIN = 2 * WIDE * BAND + 1.0  # m: the farthest from its line a cross-section reads (stretches_of)
# A line a few metres wide (notch_width) has its banks within a tile of its line: read half as far
# off as its relief, it keeps more than this share of its relief, where a natural valley's flanks
# rise over its whole width. Only lines that do are fitted for their width (fits cost time).
NOTCH_NEAR_SHARE = 0.5


class _Sections:
    """The cross-sections (:func:`queries.profile.stretches_of`) of the matches' centre lines, fitted
    at most once each, from the lattice's stored nodes gathered once: the fits cost time."""

    def __init__(self, lattice: NodeLattice, geoms: list[shapely.Geometry], measure: Measure) -> None:
        self.lattice, self.geoms, self.measure = lattice, geoms, measure
        self._nodes: Nodes | None = None
        self._pieces: dict[tuple[int, float], list[Stretch]] = {}

    def of(self, k: int, *, band: float = BAND) -> list[Stretch]:
        self.fit([k], band=band)
        return self._pieces[k, band]

    def fit(self, ks: Iterable[int], *, band: float = BAND) -> None:
        """Fits the cross-sections of the matches ``ks`` not fitted yet, all together."""
        todo = [int(k) for k in dict.fromkeys(ks) if (k, band) not in self._pieces]
        if not todo:
            return
        if self._nodes is None:
            # only the nodes the fits can read: the whole lattice's index costs more than the fits
            boxes = [g.bounds for g in self.geoms if not g.is_empty]
            self._nodes = Nodes.of(*self.lattice.points_near(boxes, READ_MARGIN))
        lines = [self.geoms[k] for k in todo]
        for k, pieces in zip(todo, stretches_of(lines, self._nodes, measure=self.measure, band=band)):
            self._pieces[k, band] = pieces


def _broad(sections: _Sections, shoulder: NDArray[np.float64], flt: Filter) -> NDArray[np.bool_]:
    """Per match, whether a shoulder that reads narrow is overruled by cross-sections at least
    ``flt.broad_width`` wide. Only those matches are measured."""
    broad = np.zeros(len(sections.geoms), bool)
    bound = flt.min_shoulder if flt.min_shoulder is not None else flt.max_shoulder
    if flt.broad_width is None or bound is None:
        return broad
    with np.errstate(invalid="ignore"):
        narrow = np.flatnonzero(shoulder <= bound)
    sections.fit(narrow)
    for k in narrow:
        broad[k] = width_of(sections.of(int(k))) >= flt.broad_width
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
    progress: Progress | None = None,
    workers: int | None = None,
) -> list[Match]:
    """Objects matching a filter at ``level`` (default: the filter's own) inside ``bbox``.

    Tiles of the filter's features join an object only where they stand out of the
    terrain on both sides (:func:`queries.relief.two_sided_relief`) by at least half
    the filter's ``min_measure``; an object's measure is the median over its tiles.

    An area too wide to read at once (a whole survey of many km²) is read in parts
    (:mod:`queries.parts`), with the same matches; a match's ``tiles`` then index its batch's
    candidate tiles. Their batches are matched in ``workers`` processes (default: one per core),
    each opening the database itself, where it is not in memory. ``progress``
    (:mod:`tdb.progress`) follows the parts and the batches.
    """
    flt = resolve(name_or_filter)
    lv = level or flt.level
    grow = _reach(lv)
    boxes = parts_for(db, version, level=lv, bbox=bbox)
    if not boxes:
        found = _find_each_at_once(db, version, [flt], level=lv, bbox=bbox, grow=grow)[0]
    else:
        tiles = part_candidates(db, version, flt, level=lv, bbox=bbox, parts=boxes, progress=progress)
        groups = batches(tiles, flt, level=lv, grow=grow, bbox=bbox)
        jobs = [_Batch(version, flt, lv, tiles.take(idx), box) for idx, box in groups]
        found = _matched(db, jobs, workers=workers, progress=progress)
    if not found or (flt.max_on_mounds is None and flt.max_by_ditches is None):
        return found
    side = _on_other_forms(db, version, found, flt, bbox=bbox, workers=workers, progress=progress)
    return [m for m, other in zip(found, side) if not other]


@dataclass(frozen=True)
class _Near:
    """A batch of lines near which the matches of other filters are asked for, the box around
    them, and how near them."""

    version: str
    forms: tuple[str, ...]
    box: Box
    lines: list[shapely.Geometry]
    near: float


PLURALS = {"mound": "mounds", "ditch": "ditches"}  # the forms a line may be the side of, named in the progress


def _on_other_forms(
    db: Database,
    version: str,
    lines: list[Match],
    flt: Filter,
    *,
    bbox: Box | None,
    workers: int | None,
    progress: Progress | None,
) -> NDArray[np.bool_]:
    """Per line, whether it is the side of another form: a mound's crest (``max_on_mounds``) or
    the lip of a ditch deeper than the line is high (``max_by_ditches``), by :func:`on_forms`
    within the reach that the line's relief is read across."""
    rules = (("mound", flt.max_on_mounds), ("ditch", flt.max_by_ditches))
    asked = tuple(form for form, most in rules if most is not None)
    reports = [labelled(progress, PLURALS[form]) for form in asked]
    found = _forms_near(db, version, lines, asked, bbox=bbox, workers=workers, reports=reports)
    heights = np.array([m.measure for m in lines])
    out = np.zeros(len(lines), bool)
    for idx, by_form in found:
        geoms = _geoms(lines, idx)
        if flt.max_on_mounds is not None:
            out[idx] |= on_forms(geoms, _geoms(by_form["mound"]), flt.max_on_mounds, reach=_ring("mound"))
        if flt.max_by_ditches is not None:
            ditches = by_form["ditch"]
            sizes = (np.array([d.measure for d in ditches]), flt.ditch_ratio * heights[idx])
            most = flt.max_by_ditches
            out[idx] |= on_forms(geoms, _geoms(ditches), most, reach=_ring("ditch"), sizes=sizes)
    return out


def _geoms(matches: list[Match], idx: Iterable[int] | None = None) -> list[shapely.Geometry]:
    return [matches[k].geometry for k in (range(len(matches)) if idx is None else idx)]


def _ring(form: str) -> float:
    """How far off a match of the built-in filter ``form`` (m) the terrain its relief is read against lies."""
    return REACH_TILES * resolve(form).level


def _forms_near(
    db: Database,
    version: str,
    lines: list[Match],
    forms: tuple[str, ...],
    *,
    bbox: Box | None,
    workers: int | None,
    reports: list[Progress | None],
) -> list[tuple[NDArray[np.intp], dict[str, list[Match]]]]:
    """Per batch of lines (:func:`queries.parts.line_batches`; the lines' indices), the matches of
    each built-in filter of ``forms`` from the candidate tiles near them alone: within the forms'
    reach and :data:`NEAR_MARGIN` tiles, which holds the whole of a mound near a line and a
    ditch's stretch beside it, and is far less than the area's candidates. Each batch's tiles and
    points are read once for all the forms, at the first one's level (the built-in mound and
    ditch filters share it). ``reports``: each form's progress."""
    level = resolve(forms[0]).level
    grow = (REACH_TILES + NEAR_MARGIN) * level
    groups = list(line_batches(shapely.bounds(_geoms(lines)), level=level, grow=grow))
    jobs = [_Near(version, forms, clipped(box, bbox), _geoms(lines, idx), grow) for idx, box in groups]
    out = []
    for done, ((idx, _), found) in enumerate(
        zip(groups, on_database(_forms_in, db, jobs, workers=workers, preload=__name__)), start=1
    ):
        out.append((idx, dict(zip(forms, found))))
        for report in reports:
            or_silent(report)("batches", done, len(jobs))
    return out


def _forms_in(db: Database, job: _Near) -> list[list[Match]]:
    """The matches of each of ``job.forms`` whose tiles lie within ``job.near`` of its lines."""
    flts = [resolve(form) for form in job.forms]
    lv, near = flts[0].level, (job.lines, job.near)
    return _find_each_at_once(db, job.version, flts, level=lv, bbox=job.box, grow=_reach(lv), near=near)


def on_forms(
    lines: list[shapely.Geometry],
    forms: list[shapely.Geometry],
    most: float,
    *,
    reach: float,
    sizes: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
) -> NDArray[np.bool_]:
    """Per line, whether ``most`` of its length or more lies within ``reach`` m of ``forms``
    (matches of another filter: a mound's top tiles, a ditch's bottom), where the terrain the
    line's relief is read against lies: the line is that form's side (a mound's crest, a ditch's
    lip). ``sizes`` (each form's measure, each line's least): a form counts for a line only where
    its measure reaches the line's least."""
    out = np.zeros(len(lines), bool)
    if not forms:
        return out
    near = [shapely.buffer(g, reach) for g in forms]
    tree = shapely.STRtree(near)
    for k, line in enumerate(lines):
        hit = tree.query(line, predicate="intersects")
        if sizes is not None:
            hit = hit[sizes[0][hit] >= sizes[1][k]]
        on = line.intersection(shapely.union_all([near[i] for i in hit])).length if len(hit) else 0.0
        out[k] = on >= most * line.length
    return out


@dataclass(frozen=True)
class _Batch:
    """A batch of a query read in parts: its candidate tiles and the box its points are read in."""

    version: str
    flt: Filter
    level: int
    tiles: Candidates
    box: Box


def _matched(db: Database, jobs: list[_Batch], *, workers: int | None, progress: Progress | None) -> list[Match]:
    """The matches of every batch, in order, in ``workers`` processes (:func:`tdb.workers.on_database`)."""
    report = or_silent(progress)
    out: list[Match] = []
    for done, found in enumerate(on_database(_match_batch, db, jobs, workers=workers, preload=__name__), start=1):
        out += found
        report("batches", done, len(jobs))
    return out


def _match_batch(db: Database, job: _Batch) -> list[Match]:
    px, py, pz, _ = db.points(job.version, level=job.level, bbox=job.box, ordered=False)
    t, lattice = job.tiles, node_lattice(px, py, pz, job.level)
    return match_tiles(t.xg, t.yg, t.code, lattice, job.flt, level=job.level, evidence=(t.own, t.facing))


def _reach(level: int) -> float:
    """How far (m) beyond its tiles a match reads the stored points: the reliefs read twice as
    far off, and the wide cross-sections (_steady_along), need them."""
    return max(SPREAD_READ * REACH_TILES * level, side_of(WIDE * BAND)[1]) + level


def _find_each_at_once(
    db: Database,
    version: str,
    flts: list[Filter],
    *,
    level: int,
    bbox: Box | None,
    grow: float,
    near: tuple[list[shapely.Geometry], float] | None = None,
) -> list[list[Match]]:
    """Each filter's matches of ``bbox``, its tiles and points read once for all; with ``near``
    (lines, distance), from the candidate tiles whose centres lie that near the lines alone."""
    xg, yg, code = db.tiles(version, level=level, bbox=bbox)
    close = np.ones(len(xg), bool)
    if near is not None:
        lines, distance = near
        centres = shapely.points(xg + level / 2, yg + level / 2)
        close[:] = False
        close[shapely.STRtree(lines).query(centres, predicate="dwithin", distance=distance)[0]] = True
    evidence = []
    for flt in flts:
        own, facing = candidates(xg, yg, code, flt, level)
        evidence.append((own & close, facing & close))
    some = [bool(np.logical_or(*e).any()) for e in evidence]
    if not any(some):
        return [[] for _ in flts]
    px, py, pz, _ = db.points(
        version,
        level=level,
        bbox=None if bbox is None else (bbox[0] - grow, bbox[1] - grow, bbox[2] + grow, bbox[3] + grow),
        ordered=False,
    )
    lattice = node_lattice(px, py, pz, level)
    return [
        match_tiles(xg, yg, code, lattice, flt, level=level, evidence=e) if any_ else []
        for flt, e, any_ in zip(flts, evidence, some)
    ]


@dataclass(frozen=True)
class _Candidates:
    """The tiles that stand out enough to join an object: indices into the tiles given, their
    relief, extreme nodes and relief read farther off (None where the filter reads none), and
    the objects they group into (each: its tiles, its measure)."""

    keep: NDArray[np.intp]
    ex: NDArray[np.float64]
    ey: NDArray[np.float64]
    relief: NDArray[np.float64]
    wide: NDArray[np.float64] | None
    objects: list[tuple[NDArray[np.intp], float]]
    # objects but for their spread, and no arm of theirs an object: matches if narrow (notch_width)
    notches: list[tuple[NDArray[np.intp], float]]

    def measured(self, g: NDArray[np.intp], flt: Filter, *, level: int, widest: bool = True) -> float | None:
        """The measure of the group ``g`` (indices into the kept tiles), None where it is not
        an object of the filter: too low, or for a line too compact, too spread (with
        ``widest``: ``flt.max_spread``) or not spread enough."""
        relief = self.relief[g]
        if not np.isfinite(relief).any():
            measure = float("nan")
        else:  # a closed form stands out most at its top (bottom); a line is measured along it
            measure = float(np.nanmax(relief) if flt.around else np.nanmedian(relief))
        if measure < flt.min_measure:  # NaN (no relief measured) is kept
            return None
        if flt.linear and elongation(self.ex[g], self.ey[g], level=level) < flt.min_elongation:
            return None
        if self.wide is not None and not _spread_passes(_spread(self.wide[g], measure), flt, widest=widest):
            return None
        return measure

    def arms(self, g: NDArray[np.intp], flt: Filter, *, level: int) -> list[tuple[NDArray[np.intp], float]]:
        """The arms of the group ``g`` that are objects of the filter, where lines at least
        :data:`ARM` long meet in it or lie apart (:func:`queries.centreline.branches`); none where
        the group is one line.

        Two lines that meet are one group of touching tiles, but neither its outline nor the
        height along it is that of one form: each arm's is."""
        if not _line_with_sides(flt):
            return []
        parts = branches(self.ex[g], self.ey[g], link=(LINK_TILES + flt.gap) * level, reach=ARM)
        if len(parts) == 1 and len(parts[0]) == len(g):
            return []
        return [(g[p], m) for p in parts if (m := self.measured(g[p], flt, level=level)) is not None]


def match_tiles(  # noqa: PLR0913 (the tiles' three arrays, their lattice and the filter)
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
    found = _objects(xg, yg, code, lattice, flt, level=level, evidence=evidence)
    if not shapes:
        return [
            Match(flt.name, level, found.keep[g], shapely.GeometryCollection(), float("nan"), m)
            for g, m in found.objects
        ]
    tiles = (xg, yg, code)
    out, failed = _lines(found.objects, found, lattice, tiles, flt, level=level)
    # A line that fails as a whole may be lines that meet: each arm is judged alone.
    arms = [arm for g, _ in failed for arm in found.arms(g, flt, level=level)]
    notches = _lines(found.notches, found, lattice, tiles, flt, level=level, narrower=flt.notch_width)[0]
    return out + _lines(arms, found, lattice, tiles, flt, level=level)[0] + notches


def _lines(
    objects: list[tuple[NDArray[np.intp], float]],
    found: _Candidates,
    lattice: NodeLattice,
    tiles: tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.uint8]],
    flt: Filter,
    *,
    level: int,
    narrower: float | None = None,
) -> tuple[list[Match], list[tuple[NDArray[np.intp], float]]]:
    """The matches among ``objects`` whose centre lines pass the filter's shoulder, height trend
    and width tests, and the objects that fail them. With ``narrower``, a match's usual
    cross-sections also read it at most that wide (m)."""
    if not objects:
        return [], []
    geoms = _centre_lines(objects, found, flt, level=level)
    shoulder = np.full(len(objects), np.nan)
    if _line_with_sides(flt) and (flt.min_shoulder is not None or flt.max_shoulder is not None):
        shoulder = shoulders(lattice, geoms, np.array([m for _, m in objects]), measure=flt.measure)
    sections = _Sections(lattice, geoms, flt.measure)
    broad = _broad(sections, shoulder, flt)
    steady = _steady_along(sections, flt) & _narrow(sections, flt)
    if narrower is not None:
        sections.fit(range(len(geoms)))
        steady &= np.array([width_of(sections.of(k)) <= narrower for k in range(len(geoms))], bool)
    xg, yg, code = tiles
    kx, ky, kc = xg[found.keep], yg[found.keep], code[found.keep]
    out, failed = [], []
    for (g, measure), geom, sh, wide, keeps_height in zip(objects, geoms, shoulder, broad, steady):
        if not (_shoulder_passes(flt, sh, wide) and keeps_height):
            failed.append((g, measure))
            continue
        shaped = _shape(geom, kx[g], ky[g], kc[g], flt, level=level)
        if shaped is not None:
            out.append(Match(flt.name, level, found.keep[g], shaped, _length(shaped, flt), measure, float(sh)))
    return out, failed


def _steady_along(sections: _Sections, flt: Filter) -> NDArray[np.bool_]:
    """Per match, whether its height (depth) keeps within ``flt.max_trend`` of itself along its
    line (:func:`queries.profile.height_trend`), read from cross-sections of the usual band and
    of one :data:`WIDE` times as wide where the line reads as wide as the usual band can see (its
    pieces' median width: one piece beside another form can read wide on its own). A
    natural spur widens downstream past that band: its fits there read the top of the form alone,
    which keeps about the same height as the spur grows; the wide band sees the spur's growth.
    Only lines long enough for a trend are measured."""
    steady = np.ones(len(sections.geoms), bool)
    if flt.max_trend is None or not _line_with_sides(flt):
        return steady
    long = [k for k, g in enumerate(sections.geoms) if g.length >= MIN_TREND_PIECES * PIECE]
    sections.fit(long)
    for k in long:
        steady[k] = not height_trend(sections.of(k)) > flt.max_trend  # NaN (no trend read) passes
    wide = [k for k in long if steady[k] and _whole_band(sections.of(k), BAND)]
    sections.fit(wide, band=WIDE * BAND)
    for k in wide:
        steady[k] = not height_trend(sections.of(k, band=WIDE * BAND)) > flt.max_trend
    return steady


def _narrow(sections: _Sections, flt: Filter) -> NDArray[np.bool_]:
    """Per match, whether it is no wider than ``flt.max_width`` (:func:`broader`). Read only where
    the filter fits its lines' cross-sections anyway (:func:`fits_lines`), and there only where
    its usual cross-sections read a line as wide as they can see, from ones :data:`WIDE` times as
    wide. A spur, or a field edge whose terrace falls back behind its bank, is a crest the usual
    band cannot see the feet of."""
    narrow = np.ones(len(sections.geoms), bool)
    if flt.max_width is None or not fits_lines(flt):
        return narrow
    sections.fit(range(len(sections.geoms)))
    whole = [k for k in range(len(sections.geoms)) if reads_whole_band(sections.of(k))]
    sections.fit(whole, band=WIDE * BAND)
    for k in whole:
        narrow[k] = not broader(sections.of(k, band=WIDE * BAND), flt.max_width)
    return narrow


def fits_lines(flt: Filter) -> bool:
    """Whether matching fits the cross-sections of the filter's lines anyway (it bounds their
    height trend), and so reads their width against ``max_width`` too. Fitting every line costs
    several times a query without it: other filters' widths are read where a query asks for
    widths (:mod:`queries.run`)."""
    return _line_with_sides(flt) and flt.max_trend is not None


def reads_whole_band(pieces: list[Stretch]) -> bool:
    """Whether the usual cross-sections read their line as wide as they can see."""
    return _whole_band(pieces, BAND)


def broader(wide: list[Stretch], most: float) -> bool:
    """Whether cross-sections :data:`WIDE` times the usual band find their line wider than
    ``most`` m, and not as wide as they can see themselves (there no feet were found)."""
    return bool(width_of(wide) > most and not _whole_band(wide, WIDE * BAND))


def _whole_band(pieces: list[Stretch], band: float) -> bool:
    """Whether the pieces (cross-sections of ``band`` m either side) read their line as wide as
    they can see: its banks lie at or beyond the band (False where none was fitted)."""
    return bool(width_of(pieces) >= 2 * band - WIDTH_STEP)


def _line_with_sides(flt: Filter) -> bool:
    """A linear form with a crest or a bottom (not a step): it has a centre line and shoulders."""
    return flt.linear and flt.measure is not Measure.STEP


def _objects(
    xg: NDArray[np.int64],
    yg: NDArray[np.int64],
    code: NDArray[np.uint8],
    lattice: NodeLattice,
    flt: Filter,
    *,
    level: int,
    evidence: tuple[NDArray[np.bool_], NDArray[np.bool_]] | None,
) -> _Candidates:
    """The tiles that stand out by the filter's measure, grouped into objects that are measured
    and, for a line, elongated enough."""
    own, facing = evidence if evidence is not None else candidates(xg, yg, code, flt, level)
    cand = np.flatnonzero(own | facing)
    if len(cand) == 0:
        empty = np.zeros(0)
        return _Candidates(cand, empty, empty, empty, None, [], [])
    # A pair of facing planes is weaker evidence than a valley in a tile: it must stand out by
    # the filter's whole measure, not a share of it, or gentle hollows chain distinct forms
    share = np.where(own[cand], TILE_SHARE, 1.0)
    ex, ey, relief = tile_relief(
        lattice,
        xg[cand],
        yg[cand],
        measure=flt.measure,
        reach=REACH_TILES * level,
        along=BREAK_LINES[code[cand]],
        around=flt.around,
    )
    with np.errstate(invalid="ignore"):
        # NaN (terrain beside unknown) is kept, but a closed form must be seen all round
        ok = relief >= share * flt.min_measure if flt.around else ~(relief < share * flt.min_measure)
    keep, relief, ex, ey = cand[ok], relief[ok], ex[ok], ey[ok]
    groups = components(xg[keep], yg[keep], code[keep], flt, level, accept=np.ones(len(keep), bool))
    wide = _relief_farther(lattice, ex, ey, code[keep], flt, level=level)
    found = _Candidates(keep, ex, ey, relief, wide, [], [])
    for g in groups:
        measure = found.measured(g, flt, level=level)
        if measure is not None:
            found.objects.append((g, measure))
            continue
        arms = found.arms(g, flt, level=level)
        found.objects.extend(arms)
        if not arms and flt.notch_width is not None:
            m = found.measured(g, flt, level=level, widest=False)
            found.notches.extend([(g, m)] if m is not None else [])
    if found.notches:
        found.notches[:] = _steep_sided(found, lattice, code[keep], flt, level=level)
    return found


def _steep_sided(
    found: _Candidates, lattice: NodeLattice, code: NDArray[np.uint8], flt: Filter, *, level: int
) -> list[tuple[NDArray[np.intp], float]]:
    """The notch candidates whose relief read half as far off as their own keeps at least
    :data:`NOTCH_NEAR_SHARE` of it (median over their tiles; NaN is kept)."""
    tiles = np.concatenate([g for g, _ in found.notches])
    near = _node_relief(lattice, found.ex[tiles], found.ey[tiles], code[tiles], flt, reach=REACH_TILES * level / 2)
    starts = np.cumsum([0] + [len(g) for g, _ in found.notches])
    out = []
    for (g, m), a, b in zip(found.notches, starts[:-1], starts[1:]):
        with np.errstate(invalid="ignore"):
            share = float(np.nanmedian(near[a:b])) / m if np.isfinite(near[a:b]).any() else float("nan")
        if not share < NOTCH_NEAR_SHARE:
            out.append((g, m))
    return out


def _relief_farther(
    lattice: NodeLattice,
    ex: NDArray[np.float64],
    ey: NDArray[np.float64],
    code: NDArray[np.uint8],
    flt: Filter,
    *,
    level: int,
) -> NDArray[np.float64] | None:
    """The relief of each tile's extreme node (``ex``, ``ey``, as its own relief picked it) read
    ``SPREAD_READ`` times farther off; None where the filter bounds no spread."""
    unbounded = flt.max_spread is None and flt.min_spread is None
    if unbounded or not flt.linear or flt.measure is Measure.STEP or len(ex) == 0:
        return None
    return _node_relief(lattice, ex, ey, code, flt, reach=SPREAD_READ * REACH_TILES * level)


def _node_relief(
    lattice: NodeLattice,
    ex: NDArray[np.float64],
    ey: NDArray[np.float64],
    code: NDArray[np.uint8],
    flt: Filter,
    *,
    reach: float,
) -> NDArray[np.float64]:
    """The relief of each tile's extreme node (``ex``, ``ey``) read ``reach`` m off, across its
    tile's break line (``code``)."""
    s = lattice.spacing
    ez = lattice.at(np.rint(ex / s).astype(np.int64), np.rint(ey / s).astype(np.int64))
    return two_sided_relief(lattice, ex, ey, ez, measure=flt.measure, reach=reach, along=BREAK_LINES[code])


def _spread(wide: NDArray[np.float64], measure: float) -> float:
    """A form's relief read farther off over its own (NaN, which passes, where either is unknown)."""
    if not np.isfinite(wide).any() or not measure > 0:
        return float("nan")
    return float(np.nanmedian(wide)) / measure


def _spread_passes(spread: float, flt: Filter, *, widest: bool = True) -> bool:
    """Whether a form's spread lies within the filter's bounds (NaN, unknown, passes): a natural
    valley or spur widens past its reach (``max_spread``, read with ``widest``); the strip between
    two ditches stands out of them alone, not of the land beyond (``min_spread``)."""
    too_wide = widest and flt.max_spread is not None and spread > flt.max_spread
    return not (too_wide or (flt.min_spread is not None and spread < flt.min_spread))


def _centre_lines(
    objects: list[tuple[NDArray[np.intp], float]], found: _Candidates, flt: Filter, *, level: int
) -> list[shapely.Geometry]:
    """Each object's line through its tiles' extreme nodes; empty for steps (their polygons or
    break lines come from the tiles)."""
    if not _line_with_sides(flt):
        return [shapely.LineString()] * len(objects)
    owner = np.repeat(np.arange(len(objects)), [len(g) for g, _ in objects])
    tiles = np.concatenate([g for g, _ in objects]) if objects else np.zeros(0, np.intp)
    link = (LINK_TILES + flt.gap) * level
    return centrelines(found.ex[tiles], found.ey[tiles], owner, link=link, count=len(objects))


def _shoulder_passes(flt: Filter, shoulder: float, wide: bool) -> bool:
    """An unmeasured shoulder passes a least one and fails a largest one: a form is a ridge (or a
    ditch) unless it is shown to be narrow."""
    if flt.min_shoulder is not None and shoulder < flt.min_shoulder and not wide:
        return False
    return not (flt.max_shoulder is not None and (not shoulder <= flt.max_shoulder or wide))


def _shape(
    line: shapely.Geometry,
    xg: NDArray[np.int64],
    yg: NDArray[np.int64],
    code: NDArray[np.uint8],
    flt: Filter,
    *,
    level: int,
) -> shapely.Geometry | None:
    """A match's geometry: its centre line, or its tiles' break lines where it has none, or the
    union of its tiles for a polygon filter; None for a line with neither (planes falling to
    one corner: a hollow)."""
    if not flt.linear:
        # tiles never overlap: a coverage union is exact and much faster than a general one
        return shapely.coverage_union_all(shapely.box(xg, yg, xg + level, yg + level))
    if line.is_empty:
        lines = [piece for piece in tile_lines(xg, yg, code, level) if piece is not None]
        line = shapely.line_merge(shapely.union_all(lines))
    return None if line.is_empty else line


def _length(geom: shapely.Geometry, flt: Filter) -> float:
    return float(geom.length) if flt.linear else 0.0
