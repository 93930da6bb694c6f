"""Co-registration of two versions on stable terrain, before they are compared.

Surveys years apart seldom share a height reference (a new geoid, a re-levelled network, a
strip offset), and their planimetry can be offset by decimetres. Compared as they are, every
tile of the overlap moves by the offset and the whole site reads as changed. So the later
surface is first aligned to the earlier one on the terrain that did not change:

- **Stable terrain** is where the two surfaces agree up to their noise: cells whose difference
  lies within 3 standard deviations of the densest difference (:func:`stable_cells`), found
  again after every step, so that real changes, vegetation read as ground and water drop out
  even where they make most of the area and pull one way.
- **Horizontal shift** by Nuth & Kääb (2011): on a slope of inclination α and aspect ψ, a shift
  of length a towards b makes dh / tan α = a · cos(b − ψ) + c. Fitted by least squares on the
  stable cells with slopes of 3–70°, the later surface resampled at the shift found, and
  iterated until the step is under 1 cm.
- **Vertical shift**: the densest stable difference (half-sample mode) after the horizontal
  shift: where vegetation taken for ground lifts one survey over part of the site, the median
  follows it and the mode stays on the ground both surveys saw.

Each estimate carries its uncertainty. Errors of LiDAR ground models are correlated over
distances of about :data:`CORRELATION` m (strips, the ground filter's choices), so the
stable cells count as one independent sample per CORRELATION² m², not one per cell.
``auto`` applies a shift only where it exceeds :data:`SIGNIFICANCE` times its uncertainty and
moves heights by more than the surveys' own ground noise (a smaller one changes nothing a
comparison can see).

The shift (dx, dy, dz) is the later survey's offset: ``after(x + dx, y + dy) − dz`` is
``before(x, y)`` on stable ground.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from queries.grids import Box, surface_grids
from tdb.bbox import box_area
from tdb.crs import check_same_horizontal, height_offset
from tdb.database import Database
from tdb.errors import DatabaseError
from tdb.evidence import LEVEL as EVIDENCE_LEVEL
from tdb.evidence import supported_change
from tdb.fill import fill_nearest
from tdb.options import Coregistration, parse
from tdb.raster import Raster
from tdb.surface import line_rebuild_at
from tdb.tiles import LEVELS, SUBGRID, NodeLattice

CORRELATION = 10.0  # m: distance over which ground-model errors are correlated
SIGNIFICANCE = 3.0  # a shift applies in ``auto`` where it exceeds this many standard errors
OUTLIER_NMADS = 3.0  # stable cells lie within this many NMADs of the median difference
MIN_SLOPE, MAX_SLOPE = 3.0, 70.0  # degrees: slopes that carry a horizontal shift
SLOPE_SCALE = 0.5  # cells: the Gaussian σ of the terrain's slope a cell is judged on (leave-one-seed-out)
STEP = 0.01  # m: the horizontal iteration stops when its step is shorter
MAX_ITERATIONS = 10
FIT_CELLS = 200_000  # most cells the horizontal fit reads
SAMPLED_SHARE = 1.0  # the surfaces are rebuilt over at least this many times FIT_CELLS cells
MIN_STABLE = 50  # stable cells needed for any estimate
# The estimator's revision, part of a stored shift's key: a shift stored by an earlier one is
# estimated again rather than reused.
ESTIMATOR = 3
SAMPLE = 50_000  # cells a spread is measured on
GRID_CELLS = 4_000_000  # most cells of the grid the shift is estimated on (coarser over large areas)
GRID_CELL = 1.0  # m: the finest cell it is estimated on; decimetre shifts need no finer grid


@dataclass(frozen=True)
class Shift:
    """The later survey's offset from the earlier one, and how well it is known.

    ``sigma_xy`` and ``sigma_z`` are standard errors (m); ``residual_nmad`` is the spread of the
    stable differences after the shift, and ``nmad``, which the level of detection takes, that of
    the change the ground evidence supports on them (the same where the versions hold no
    evidence); ``stable_share`` the share of compared cells found stable.
    ``horizontal`` and ``vertical`` say which parts apply. ``datum_dz`` is how far the later
    survey's heights stand over the earlier's by their vertical CRSs (the transformation
    ``datum`` names, :func:`tdb.crs.height_offset`): applied always, before anything is estimated,
    so ``dz`` is what is left beyond it.
    """

    dx: float = 0.0
    dy: float = 0.0
    dz: float = 0.0
    sigma_xy: float = float("nan")
    sigma_z: float = float("nan")
    nmad: float = float("nan")
    stable_share: float = float("nan")
    residual_nmad: float = float("nan")
    method: Coregistration = Coregistration.NONE
    horizontal: bool = False
    vertical: bool = False
    datum_dz: float = 0.0
    datum: str = ""

    @property
    def applied(self) -> bool:
        """Whether any part of the shift applies."""
        return self.horizontal or self.vertical or self.datum_dz != 0.0

    @property
    def z_offset(self) -> float:
        """How far the later survey's heights are lowered to meet the earlier's (m)."""
        return self.datum_dz + (self.dz if self.vertical else 0.0)

    def apply(self, later: Raster) -> Raster:
        """``later`` aligned to the earlier survey: resampled at the horizontal shift, less the
        vertical one (the parts that apply)."""
        data = later.data
        if self.horizontal:
            data = resample(data, self.dx / later.cell, -self.dy / later.cell)
        if self.z_offset:
            data = data - self.z_offset
        return replace(later, data=data)

    def to_json(self) -> dict[str, Any]:
        """The shift as a GeoJSON collection's ``coregistration`` member."""

        def r(v: float) -> float | None:
            return None if not np.isfinite(v) else round(float(v), 4)

        return {
            "method": str(self.method),
            "dx": r(self.dx),
            "dy": r(self.dy),
            "dz": r(self.dz),
            "sigma_xy": r(self.sigma_xy),
            "sigma_z": r(self.sigma_z),
            "nmad": r(self.nmad),
            "residual_nmad": r(self.residual_nmad),
            "stable_share": r(self.stable_share),
            "horizontal_applied": bool(self.horizontal),
            "vertical_applied": bool(self.vertical),
            "datum_dz": r(self.datum_dz) or 0.0,
            "datum": self.datum,
        }

    @classmethod
    def from_json(cls, doc: dict[str, Any]) -> Shift:
        """The shift :meth:`to_json` wrote."""

        def f(key: str, default: float = float("nan")) -> float:
            value = doc.get(key)
            return default if value is None else float(value)

        return cls(
            dx=f("dx", 0.0),
            dy=f("dy", 0.0),
            dz=f("dz", 0.0),
            sigma_xy=f("sigma_xy"),
            sigma_z=f("sigma_z"),
            nmad=f("nmad"),
            stable_share=f("stable_share"),
            residual_nmad=f("residual_nmad"),
            method=parse(Coregistration, doc.get("method", "none")),
            horizontal=bool(doc.get("horizontal_applied")),
            vertical=bool(doc.get("vertical_applied")),
            datum_dz=f("datum_dz", 0.0),
            datum=str(doc.get("datum", "")),
        )

    def describe(self) -> str:
        """One line for a person: the shift, its uncertainty, what applies and the residual."""
        parts = [self._plan(3), f"dz {self.dz:+.3f} m (± {self.sigma_z:.3f})"]
        applied = [name for name, on in (("horizontal", self.horizontal), ("vertical", self.vertical)) if on]
        text = (
            f"{', '.join(parts)}; applied: {' and '.join(applied) or 'none'}; {self._spread()}; "
            f"{100 * self.stable_share:.0f} % of cells stable"
        )
        return f"after the vertical datums' {self.datum_dz:+.3f} m: {text}" if self.datum else text

    def title(self) -> str:
        """The shift in a few words, for a map's title."""
        applied = "".join(name for name, on in (("xy", self.horizontal), ("z", self.vertical)) if on)
        datum = f"datums {self.datum_dz:+.2f} m, then " if self.datum else ""
        return (
            f"{datum}shift {self._plan(2)}, dz {self.dz:+.2f} "
            f"(± {self.sigma_z:.2f}) m, {'applied: ' + applied if applied else 'not applied'}; "
            f"NMAD on stable ground {self._residual():.3f} m"
        )

    def _plan(self, decimals: int) -> str:
        """The horizontal shift and its uncertainty, or why there is none."""
        if self.method is Coregistration.VERTICAL:
            return "dx, dy not estimated"
        if not np.isfinite(self.sigma_xy):
            return "dx, dy not found (too little sloped stable ground)"
        d = decimals
        return f"dx {self.dx:+.{d}f} m, dy {self.dy:+.{d}f} m (± {self.sigma_xy:.{d}f})"

    def _residual(self) -> float:
        """The residual spread; records written before it was kept hold only the supported one."""
        return self.residual_nmad if np.isfinite(self.residual_nmad) else self.nmad

    def _spread(self) -> str:
        """The residual spread, and the part of it the ground evidence supports where that differs."""
        text = f"NMAD on stable ground {self._residual():.3f} m"
        if np.isfinite(self.residual_nmad) and abs(self.residual_nmad - self.nmad) >= 0.0005:
            text += f", {self.nmad:.3f} m of the change ground returns support"
        return text


def coregister(
    db: Database,
    before: str,
    after: str,
    *,
    level: int = 2,
    bbox: Box | None = None,
    method: str | Coregistration = Coregistration.AUTO,
    reuse: bool = True,
) -> Shift:
    """The shift that aligns version ``after`` to ``before`` (:func:`estimate_shift`), on their
    rebuilt surfaces over the tiles both hold in ``bbox``. Where the two declare vertical CRSs
    of different datums and PROJ holds a transformation between them offline
    (:func:`tdb.crs.height_offset`), the later heights are first expressed in the earlier's
    reference, with every method (``none`` too); the shift estimated is what is left.

    A shift found is stored in the database (where it is writable), and with ``reuse`` one
    stored for the same versions, method, level and area is returned instead of estimated again.

    Raises
    ------
    CRSError
        If the versions' horizontal coordinate systems differ.
    InputError
        If they share no tiles there.
    """
    at = site(db, before)
    check_same_horizontal(db.crs(before), db.crs(after), names=(before, after), at=at)
    datum = None if at is None else height_offset(db.crs(before), db.crs(after), at=at)
    datums: dict[str, Any] = {} if datum is None else {"datum_dz": datum.dz, "datum": datum.description}
    m = parse(Coregistration, method)
    if m is Coregistration.NONE:
        return Shift(method=m, **datums)
    where = "all" if bbox is None else ",".join(f"{v:.3f}" for v in bbox)
    setting = f"{m} level {level} {where} estimator {ESTIMATOR}"
    stored = db.coregistration(before, after, setting) if reuse else None
    if stored is not None:
        return Shift.from_json(stored)
    first, second = estimation_grids(db, before, after, level=level, bbox=bbox)
    if datum is not None:
        second = replace(second, data=second.data - datum.dz)
    held = np.isfinite(first.data) & np.isfinite(second.data)
    depth = (depth_grid(db, before, first, held), depth_grid(db, after, first, held))
    shift = estimate_shift(first, second, method=m, noise=_noise(db, before, after), depth=depth)
    shift = replace(shift, **datums)
    with contextlib.suppress(DatabaseError):  # a read-only database: the shift is found again next time
        db.store_coregistration(before, after, setting, shift.to_json())
    return shift


def estimation_grids(
    db: Database, before: str, after: str, *, level: int = 2, bbox: Box | None = None
) -> tuple[Raster, Raster]:
    """The two surfaces a shift is estimated on: rebuilt from the kept points, on a grid of
    :data:`GRID_CELL` m (coarser where that would exceed :data:`GRID_CELLS` cells), over
    whole 16 m blocks of the area holding about :data:`SAMPLED_SHARE` × :data:`FIT_CELLS` cells."""
    extent = bbox or _extent(db, before)
    cells = GRID_CELLS if extent is None else box_area(extent) / GRID_CELL**2
    # The fit reads FIT_CELLS cells: blocks holding a few times as many are all it needs rebuilt.
    # Counted where the survey holds tiles: stripes spaced for a mostly empty box (a corridor,
    # two sites) would miss its data altogether.
    held = len(db.tiles(before, level=max(LEVELS), bbox=bbox, ordered=False)[0]) * max(LEVELS) ** 2
    blocks = max(1, int(min(cells, held / GRID_CELL**2) // (SAMPLED_SHARE * FIT_CELLS)))
    return surface_grids(
        db,
        before,
        after,
        level=level,
        bbox=bbox,
        max_cells=int(min(GRID_CELLS, max(cells, 1))),
        fit=True,
        blocks=blocks,
    )


DEPTH_STRIP = 1024.0  # m: the evidence is read in strips this wide, so a large area's stays out of memory


def depth_grid(db: Database, version: str, grid: Raster, held: NDArray[np.bool_]) -> NDArray[np.float64]:
    """How far the version's surface may stand over the ground it saw (its evidence's standing,
    :mod:`tdb.evidence`) at the ``held`` cells of ``grid``, from the 2 m tile holding each centre
    (0 elsewhere and where the version holds none)."""
    out = np.zeros(grid.shape)
    rows, cols = np.nonzero(held)
    x = grid.x0 + (cols + 0.5) * grid.cell
    y = grid.y1 - (rows + 0.5) * grid.cell
    strip = np.floor(x / DEPTH_STRIP).astype(np.int64)
    for s in np.unique(strip):
        here = np.flatnonzero(strip == s)
        bbox = (float(x[here].min()), float(y[here].min()), float(x[here].max()), float(y[here].max()))
        evidence = db.evidence(version, bbox=bbox)
        if len(evidence) == 0:
            continue
        i, j = evidence.xg // EVIDENCE_LEVEL, evidence.yg // EVIDENCE_LEVEL
        depth = np.zeros((int(j.max() - j.min()) + 1, int(i.max() - i.min()) + 1))
        depth[j - j.min(), i - i.min()] = evidence.standing
        ci = np.floor(x[here] / EVIDENCE_LEVEL).astype(np.int64) - i.min()
        cj = np.floor(y[here] / EVIDENCE_LEVEL).astype(np.int64) - j.min()
        inside = (ci >= 0) & (cj >= 0) & (ci < depth.shape[1]) & (cj < depth.shape[0])
        out[rows[here[inside]], cols[here[inside]]] = depth[cj[inside], ci[inside]]
    return out


def _noise(db: Database, before: str, after: str) -> float:
    """The two surveys' ground noise together (m): a shift under it changes nothing."""
    terms = [db.version(v).stats.noise_m for v in (before, after)]
    return float(np.sqrt(sum(t * t for t in terms if t is not None)))


def _extent(db: Database, version: str) -> Box | None:
    return db.version(version).stats.bounds


def site(db: Database, version: str) -> tuple[float, float] | None:
    """The centre of a version's extent, where two coordinate systems are compared."""
    b = db.version(version).stats.bounds
    return None if b is None else ((b[0] + b[2]) / 2, (b[1] + b[3]) / 2)


def shifted_lattice(lattice: NodeLattice, shift: Shift) -> NodeLattice:
    """The later survey's node lattice aligned to the earlier one: less the vertical shift and,
    where the horizontal one applies, every tile rebuilt in full (the line rebuild) and read at
    the shifted positions."""
    if not shift.applied or lattice.z.size == 0:
        return lattice
    z = lattice.z
    if shift.horizontal:
        # cubic: a bilinear read between nodes blunts a wall's or a ridge's crest into a change
        z = resample(_rebuilt(lattice), shift.dx / lattice.spacing, shift.dy / lattice.spacing, order=3)
    if shift.z_offset:
        z = z - shift.z_offset
    return replace(lattice, z=z)


def _rebuilt(lattice: NodeLattice) -> NDArray[np.float64]:
    """The lattice with every tile it covers rebuilt at all its nodes (NaN where a tile has too
    little to rebuild)."""
    step = SUBGRID - 1
    rows, cols = lattice.z.shape
    ti = np.arange(lattice.i0 // step, (lattice.i0 + cols - 1) // step + 1)
    tj = np.arange(lattice.j0 // step, (lattice.j0 + rows - 1) // step + 1)
    gi, gj = np.meshgrid(ti, tj)
    size = lattice.spacing * step
    xg, yg = np.rint(gi.ravel() * size).astype(np.int64), np.rint(gj.ravel() * size).astype(np.int64)
    nodes = line_rebuild_at(lattice.tile_nodes(xg, yg)).reshape(-1, SUBGRID, SUBGRID)
    out = np.full(lattice.z.shape, np.nan)
    d = np.arange(SUBGRID)
    ni = (gi.ravel() * step - lattice.i0)[:, None, None] + d[None, None, :]
    nj = (gj.ravel() * step - lattice.j0)[:, None, None] + d[None, :, None]
    ni, nj = np.broadcast_to(ni, nodes.shape), np.broadcast_to(nj, nodes.shape)
    ok = (ni >= 0) & (nj >= 0) & (ni < cols) & (nj < rows) & np.isfinite(nodes)
    out[nj[ok], ni[ok]] = nodes[ok]
    return out


def nmad(values: NDArray[np.float64]) -> float:
    """Normalised median absolute deviation: the standard deviation of normal values, robustly."""
    if len(values) == 0:
        return float("nan")
    return float(1.4826 * np.median(np.abs(values - np.median(values))))


def resample(data: NDArray[np.float64], di: float, dj: float, *, order: int = 1) -> NDArray[np.float64]:
    """``data`` read at (column + di, row + dj), bilinearly (``order`` 1) or by cubic splines
    (3); NaN where a neighbour is NaN or outside."""
    if order == 1:
        return _shift_bilinear(data, di, dj)
    rows, cols = data.shape
    jj, ii = np.mgrid[0:rows, 0:cols].astype(np.float64)
    valid = np.isfinite(data)
    filled = fill_nearest(data) if valid.any() and not valid.all() else np.where(valid, data, 0.0)
    coords = np.array([jj + dj, ii + di])
    values = ndimage.map_coordinates(filled, coords, order=order, mode="nearest")
    weight = ndimage.map_coordinates(valid.astype(np.float64), coords, order=1, mode="constant", cval=0.0)
    return np.where(weight > 1 - 1e-6, values, np.nan)


def _shift_bilinear(data: NDArray[np.float64], di: float, dj: float) -> NDArray[np.float64]:
    """The same shift for every cell: four shifted copies weighted, no coordinate arrays."""
    rows, cols = data.shape
    pad = int(max(abs(np.floor(di)), abs(np.floor(dj)))) + 2
    padded = np.pad(data, pad, constant_values=np.nan)
    out = np.zeros((rows, cols))
    for dr, dc, w in _bilinear_weights(di, dj):
        out += w * padded[pad + dr : pad + dr + rows, pad + dc : pad + dc + cols]  # NaN anywhere it is read
    return out


def _bilinear_weights(di: float, dj: float) -> list[tuple[int, int, float]]:
    """The (row offset, column offset, weight) of the neighbours a read at (column + di, row + dj)
    mixes, those of no weight left out."""
    ki, kj = int(np.floor(di)), int(np.floor(dj))
    fi, fj = di - ki, dj - kj
    corners = ((0, 0, (1 - fi) * (1 - fj)), (0, 1, fi * (1 - fj)), (1, 0, (1 - fi) * fj), (1, 1, fi * fj))
    return [(kj + a, ki + b, w) for a, b, w in corners if w > 1e-12]


def _bilinear_at(
    data: NDArray[np.float64], row: NDArray[np.intp], col: NDArray[np.intp], di: float, dj: float
) -> NDArray[np.float64]:
    """``data`` read at (column + di, row + dj) of the given cells, bilinearly, as
    :func:`resample` reads it; NaN where a neighbour is NaN or outside."""
    rows, cols = data.shape
    out = np.zeros(len(row))
    for dr, dc, w in _bilinear_weights(di, dj):
        r, c = row + dr, col + dc
        inside = (r >= 0) & (r < rows) & (c >= 0) & (c < cols)
        out += w * np.where(inside, data[np.clip(r, 0, rows - 1), np.clip(c, 0, cols - 1)], np.nan)
    return out


def half_sample_mode(values: NDArray[np.float64]) -> float:
    """The densest value (Bickel's half-sample mode): the shortest interval holding half the
    values, halved again and again. Unlike the median it stays on the values that agree when a
    large share of the others is pulled to one side."""
    v = np.sort(values[np.isfinite(values)])
    if len(v) == 0:
        return float("nan")
    while len(v) > 3:
        half = (len(v) + 1) // 2
        start = int(np.argmin(v[half - 1 :] - v[: len(v) - half + 1]))
        v = v[start : start + half]
    return float(np.mean(v))


def stable_cells(dh: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Cells whose difference lies within :data:`OUTLIER_NMADS` standard deviations of the
    densest difference. Ground that did not change agrees between two surveys; changes, and
    vegetation one survey took for ground, pull the rest to either side, often mostly to one.
    So the centre is the half-sample mode, and the spread is found by clipping at 3 σ about it
    and measuring again (NMAD) until it settles, starting from the quarter of the cells
    closest to the centre (the 25th percentile of |dh − centre| is 0.3186 σ for normal errors)."""
    finite = np.isfinite(dh)
    values = dh[finite]
    if len(values) < MIN_STABLE:
        return finite
    centre = half_sample_mode(values)
    # the spread is a statistic of the whole field: a regular subsample of 50 000 cells reads it
    deviation = np.abs(values[:: max(1, len(values) // SAMPLE)] - centre)
    spread = max(float(np.percentile(deviation, 25)) / 0.3186, 1e-3)
    for _ in range(MAX_ITERATIONS):
        inside = deviation <= OUTLIER_NMADS * spread
        now = max(1.4826 * float(np.median(deviation[inside])), 1e-3)
        if abs(now - spread) < 1e-4:
            break
        spread = now
    return finite & (np.abs(dh - centre) <= OUTLIER_NMADS * spread)


def estimate_shift(
    before: Raster,
    after: Raster,
    *,
    method: str | Coregistration = Coregistration.AUTO,
    noise: float = 0.0,
    depth: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
) -> Shift:
    """The shift that aligns ``after`` to ``before`` (two surfaces on one grid), by ``method``.

    ``none`` estimates nothing; ``vertical`` the vertical shift alone; ``nuth-kaab`` both,
    applied whatever their size; ``auto`` both, each applied only where it is significant
    (beyond :data:`SIGNIFICANCE` standard errors) and material: where it moves heights by more
    than ``noise`` (m, the surveys' own ground noise), a horizontal shift through the slope of
    the terrain's steepest tenth. The estimates are reported whether they apply or not.

    With ``depth``, each surface's depth over its own ground returns per cell
    (:mod:`tdb.evidence`), the spread (``nmad``) is that of the change the ground evidence
    supports (:func:`tdb.evidence.supported_change`) on stable terrain, as a comparison tests it:
    where vegetation taken for ground lifts one surface over ground that survey saw, the
    difference there is no error of the surfaces.
    """
    m = parse(Coregistration, method)
    if m is Coregistration.NONE:
        return Shift(method=m)
    cell = before.cell
    dx = dy = 0.0
    sigma_xy = float("nan")
    if m is not Coregistration.VERTICAL:
        dx, dy, sigma_xy = _nuth_kaab(before.data, after.data, cell)
    found = bool(np.isfinite(sigma_xy))
    length = float(np.hypot(dx, dy))
    horizontal = found and (
        m is Coregistration.NUTH_KAAB
        or (
            m is Coregistration.AUTO
            and length > SIGNIFICANCE * sigma_xy
            and length * _steep_slope(before.data, cell) > noise
        )
    )
    aligned = resample(after.data, dx / cell, -dy / cell) if horizontal else after.data
    dh = aligned - before.data
    stable = stable_cells(dh)
    values = dh[stable]
    share = len(values) / max(int(np.isfinite(dh).sum()), 1)
    if len(values) < MIN_STABLE:
        return Shift(dx=dx, dy=dy, sigma_xy=sigma_xy, stable_share=share, method=m)
    dz = half_sample_mode(values)  # not the median: see stable_cells
    residual = nmad(values)  # the vertical shift moves no spread
    sigma_z = residual / np.sqrt(_independent(len(values), cell))
    vertical = m is not Coregistration.AUTO or (abs(dz) > SIGNIFICANCE * sigma_z and abs(dz) > noise)
    spread = residual if depth is None else _supported_spread(dh - (dz if vertical else 0.0), depth)
    return Shift(
        dx=dx,
        dy=dy,
        dz=dz,
        sigma_xy=sigma_xy,
        sigma_z=float(sigma_z),
        nmad=spread,
        stable_share=share,
        residual_nmad=residual,
        method=m,
        horizontal=bool(horizontal),
        vertical=bool(vertical),
    )


def _supported_spread(
    residual: NDArray[np.float64], depth: tuple[NDArray[np.float64], NDArray[np.float64]]
) -> float:
    """NMAD of the supported change on the cells where it is stable. Where the evidence cuts
    most of them to zero it is small, and the surveys' own noise bounds the level of detection."""
    supported = supported_change(residual.reshape(-1, 1), np.stack([d.ravel() for d in depth]))[:, 0]
    return nmad(supported[stable_cells(supported)])


STEEP = 90  # percentile: a horizontal shift shows on the steepest tenth of the terrain


def _steep_slope(surface: NDArray[np.float64], cell: float) -> float:
    """The inclination (rise over run) of the steep part of a surface: a horizontal shift moves
    heights there, on ditch banks and walls, where changes are read, far more than on the flats."""
    d_row, d_col = np.gradient(surface, cell)
    tan = np.hypot(np.asarray(d_row), np.asarray(d_col))
    finite = tan[np.isfinite(tan)]
    return float(np.percentile(finite, STEEP)) if len(finite) else 0.0


def _independent(cells: int, cell: float) -> float:
    """Independent samples among ``cells`` stable cells of side ``cell`` (see the module)."""
    return float(max(1.0, min(cells, cells * cell * cell / CORRELATION**2)))


def _smoothed_slope(surface: NDArray[np.float64], cell: float) -> NDArray[np.float64]:
    """The inclination (rise over run) of ``surface`` smoothed by a Gaussian of :data:`SLOPE_SCALE`
    cells, its holes (NaN) left out of the weights and kept as holes."""
    held = np.isfinite(surface)
    weight = ndimage.gaussian_filter(held.astype(float), SLOPE_SCALE)
    with np.errstate(invalid="ignore", divide="ignore"):
        smooth = ndimage.gaussian_filter(np.where(held, surface, 0.0), SLOPE_SCALE) / weight
    d_row, d_col = np.gradient(np.where(held, smooth, np.nan), cell)
    return np.hypot(np.asarray(d_row), np.asarray(d_col))


def _nuth_kaab(before: NDArray[np.float64], after: NDArray[np.float64], cell: float) -> tuple[float, float, float]:
    """Horizontal shift (dx, dy) of ``after`` from ``before`` and its standard error (m).

    The fit runs on a fixed random sample of at most :data:`FIT_CELLS` cells, read at each
    iteration's shift where they lie: a shift is a handful of numbers, and a million equations
    say no more of them than two hundred thousand do, at a fraction of the cost."""
    d_row, gx = np.gradient(before, cell)
    gy = -np.asarray(d_row)  # rows run north to south
    gx = np.asarray(gx)
    tan = np.hypot(gx, gy)
    # A cell carries a shift where the terrain around it is sloped, not its noise alone: on gentle
    # ground the few cells whose own gradient passes the bound are those where the noise adds to
    # the slope, and their differences lean the fit along it (a 2 % plane read a 4 m shift).
    least = np.tan(np.radians(MIN_SLOPE))
    sloped = (_smoothed_slope(before, cell) > least) & (tan > least) & (tan < np.tan(np.radians(MAX_SLOPE)))
    cells = np.flatnonzero(np.isfinite(before).ravel())
    share = min(1.0, FIT_CELLS / max(len(cells), 1))
    if share < 1.0:
        cells = np.sort(np.random.default_rng(0).choice(cells, FIT_CELLS, replace=False))
    row, col = np.divmod(cells, before.shape[1])
    gx, gy, tan, sloped = gx[row, col], gy[row, col], tan[row, col], sloped[row, col]
    first = before[row, col]
    dx = dy = 0.0
    sigma = float("nan")
    for _ in range(MAX_ITERATIONS):
        dh = _bilinear_at(after, row, col, dx / cell, -dy / cell) - first
        use = sloped & stable_cells(dh)
        if use.sum() < MIN_STABLE:
            return 0.0, 0.0, float("nan")
        # after(x) ≈ before(x − d) + c, so dh ≈ −∇before · d + c; divided by tan α (Nuth & Kääb):
        # dh / tan α = −(ux dx + uy dy) + c / tan α, with u the unit upslope direction
        t = tan[use]
        a = np.column_stack([-gx[use] / t, -gy[use] / t, 1.0 / t])
        y = dh[use] / t
        fit, *_ = np.linalg.lstsq(a, y, rcond=None)
        residual = y - a @ fit
        # standard error from the residual's robust spread and the independent samples of the
        # area the sampled cells stand for
        independent = min(len(y), _independent(int(len(y) / share), cell))
        scale = nmad(residual) ** 2 * len(y) / independent
        cov = np.linalg.pinv(a.T @ a) * scale
        sigma = float(np.sqrt(max(cov[0, 0] + cov[1, 1], 0.0) / 2))
        dx, dy = dx + float(fit[0]), dy + float(fit[1])
        if np.hypot(fit[0], fit[1]) < STEP:
            break
    return dx, dy, sigma
