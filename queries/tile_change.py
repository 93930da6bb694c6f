"""Whether each tile's surface moved between two versions, beyond its level of detection.

The tile-level half of change detection (:mod:`queries.changes`): the level of detection from
both surveys' noise and their surfaces' errors, grown per tile by the ground evidence; each
version's stored points around the tiles on the level's node lattice; and the test of a tile,
at its 3 × 3 nodes of the surfaces rebuilt from kept points. A tile's answer depends on its own
nodes and evidence alone, so it is the same whatever area is read around it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from queries.coregister import Shift
from queries.match import REACH_TILES
from queries.relief import nan_extreme
from tdb.database import Database
from tdb.evidence import GAP_SLOPE, MIN_SUPPORT, TileEvidence, missed_relief, supported_change
from tdb.evidence import LEVEL as EVIDENCE_LEVEL
from tdb.surface import line_rebuild_at
from tdb.tiles import SUBGRID, NodeLattice, node_lattice

MIN_LOD = 0.10


def level_of_detection(db: Database, a: str, b: str, *, shift: Shift | None = None) -> float:
    """95 % level of detection from both surveys' ground noise and the error of their
    surfaces rebuilt from the kept points (the reduction RMSE), at least ``MIN_LOD``; with a
    co-registration ``shift``, at least 1.96 × the residual spread it left on stable ground."""
    residual = 1.96 * shift.nmad if shift is not None and np.isfinite(shift.nmad) else 0.0
    return max(residual, _noise_lod(db, a, b))


def _noise_lod(db: Database, a: str, b: str) -> float:
    terms = []
    for name in (a, b):
        stats = db.version(name).stats
        noise = stats.noise_m if stats.noise_m is not None else 0.05
        terms += [noise, stats.reduction.rmse_m or 0.0]
    return max(MIN_LOD, 1.96 * float(np.sqrt(np.sum(np.square(terms)))))


@dataclass(frozen=True)
class Sides:
    """What each version's ground evidence says of tiles that a region's gates read
    (:mod:`queries.changes`): the versions on the first axis, the tiles on the last."""

    layer: NDArray[np.float64]  # (2, tiles) m: the layer each version's surface lies in (tdb.evidence)
    # (2, 2, tiles) m: per version, the lowest and highest of its returns not taken for ground over
    # its surface (tdb.evidence; NaN where none, or where the version holds no such evidence)
    over: NDArray[np.float64]
    # (2, 2, tiles): per version, the share of its pulses taken for ground and those pulses per m²
    # (tdb.evidence; NaN where it holds none, or no such evidence)
    pulses: NDArray[np.float64]
    # (2, tiles): per version, how many of its ground returns (last returns taken for ground) the
    # tile holds (NaN where the version holds no such evidence)
    returns: NDArray[np.float64]

    FIELDS = ("layer", "over", "pulses", "returns")

    @classmethod
    def empty(cls, tiles: int = 0) -> Sides:
        """What no evidence says of ``tiles`` tiles: no layer, and NaN."""
        none = np.full((2, tiles), np.nan)
        return cls(np.zeros((2, tiles)), np.full((2, 2, tiles), np.nan), np.full((2, 2, tiles), np.nan), none)

    def take(self, at: NDArray[np.intp]) -> Sides:
        """The tiles ``at``."""
        return Sides(*(getattr(self, f)[..., at] for f in self.FIELDS))

    @staticmethod
    def joined(parts: list[Sides]) -> Sides:
        """The tiles of ``parts``, one after the other."""
        return Sides(*(np.concatenate([getattr(p, f) for p in parts], axis=-1) for f in Sides.FIELDS))


@dataclass(frozen=True)
class TileJudgement:
    """Per tile of a level, what both versions' ground evidence lets a change claim."""

    lod: NDArray[np.float64]  # m: the level of detection
    seen: NDArray[np.bool_]  # both versions saw the tile's ground well enough
    depth: NDArray[np.float64]  # (2, tiles) m: how far each version's surface may stand above its ground
    reach: NDArray[np.float64]  # (2, tiles) m: how far each version's nodes lie from its ground returns (RMS)
    sides: Sides


def tile_lod(
    db: Database, a: str, b: str, xg: NDArray[np.int64], yg: NDArray[np.int64], *, level: int, lod: float
) -> TileJudgement:
    """Per tile of ``level`` (corners ``xg``, ``yg``), the level of detection grown by both
    versions' ground evidence (:mod:`tdb.evidence`), at least ``lod``; whether both versions
    saw the tile well enough for a change to be claimed; and each version's depth of surface over
    its ground returns. A coarser tile takes the mean of its 2 m tiles. Where a version holds no
    evidence (stored before it was kept) the tile keeps ``lod``, counts as seen and has depth 0."""
    bbox = (float(xg.min()), float(yg.min()), float(xg.max() + level), float(yg.max() + level))
    variance = np.zeros(len(xg))
    seen = np.ones(len(xg), bool)
    depth = np.zeros((2, len(xg)))
    reach = np.zeros((2, len(xg)))
    sides = Sides.empty(len(xg))
    for side, name in enumerate((a, b)):
        evidence = db.evidence(name, bbox=bbox)
        if len(evidence) == 0:
            continue
        rmse = db.version(name).stats.reduction.rmse_m or 0.0
        fine = _at_level(evidence, xg, yg, level)
        sigma2, support, depth[side], sides.layer[side] = _per_tile(fine, len(xg), level)
        sides.over[side] = _over(fine, len(xg), level)
        sides.pulses[side], sides.returns[side] = _grounded(fine, len(xg), level)
        reach[side] = _rms(fine.reach, len(xg), level)
        variance += np.nan_to_num(sigma2, nan=0.0) + rmse**2
        seen &= support >= MIN_SUPPORT
    return TileJudgement(np.maximum(lod, 1.96 * np.sqrt(variance)), seen, depth, reach, sides)


def _rms(values: NDArray[np.float32], tiles: int, level: int) -> NDArray[np.float64]:
    """The RMS of ``values`` over the 2 m tiles making up each tile of ``level`` (0 where none is held)."""
    per = (tiles, (level // EVIDENCE_LEVEL) ** 2)
    with np.errstate(invalid="ignore"):
        return np.sqrt(np.nan_to_num(np.nanmean(np.square(values.astype(float)).reshape(per), axis=1)))


def _at_level(evidence: TileEvidence, xg: NDArray[np.int64], yg: NDArray[np.int64], level: int) -> TileEvidence:
    """The evidence of the 2 m tiles making up each tile of ``level``, tile by tile."""
    k = level // EVIDENCE_LEVEL
    if k == 1:
        return evidence.at(xg, yg)
    fx, fy = split_keys(xg // EVIDENCE_LEVEL // k, yg // EVIDENCE_LEVEL // k, k)
    return evidence.at(fx * EVIDENCE_LEVEL, fy * EVIDENCE_LEVEL)


def _over(e: TileEvidence, tiles: int, level: int) -> NDArray[np.float64]:
    """(2, tiles): the lowest and the highest return not taken for ground over the surface among
    the 2 m tiles making up each tile of ``level`` (``e``: theirs, :func:`_at_level`; NaN where none)."""
    per = (tiles, (level // EVIDENCE_LEVEL) ** 2)
    low, high = e.over_low.astype(float).reshape(per), e.over_high.astype(float).reshape(per)
    return np.stack([nan_extreme(low, -1.0, axis=1), nan_extreme(high, 1.0, axis=1)])


def _grounded(e: TileEvidence, tiles: int, level: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Over the 2 m tiles making up each tile of ``level`` (``e``: theirs, :func:`_at_level`):
    (2, tiles) the share of the pulses taken for ground and those pulses per m² (NaN where none
    holds any), and (tiles) how many ground returns they hold (NaN where none has its pulses
    counted)."""
    per = (tiles, (level // EVIDENCE_LEVEL) ** 2)
    density, share = e.pulses.astype(float).reshape(per), e.ground_share.astype(float).reshape(per)
    counted = np.isfinite(density)
    held = counted & np.isfinite(share)  # a tile without pulses has no share
    pulses = np.where(held, density, 0.0).sum(axis=1)
    grounded = np.where(held, density * share, 0.0).sum(axis=1)
    count = held.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        rates = np.stack(
            [np.where(pulses > 0, grounded / pulses, np.nan), np.where(count > 0, grounded / count, np.nan)]
        )
    return rates, np.where(counted.any(axis=1), grounded * EVIDENCE_LEVEL**2, np.nan)


def _per_tile(
    e: TileEvidence, tiles: int, level: int
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Mean variance of the relief hidden in gaps, mean support, mean standing (how far the
    surface may stand over the ground seen, 0 where nothing is held) and mean layer of the 2 m
    tiles making up each tile of ``level`` (``e``: theirs, :func:`_at_level`). A tile's own lift
    stays out: a wall built or a bank lifts the tiles along its edges as vegetation does (the
    layer, the lift over an area, does not)."""
    k = level // EVIDENCE_LEVEL
    variance = (GAP_SLOPE * e.gap.astype(float)) ** 2
    depth = e.standing
    per = (tiles, k * k)
    with np.errstate(invalid="ignore"):
        mean = np.nanmean(variance.reshape(per), axis=1)
    layer = np.nan_to_num(e.layer.astype(float)).reshape(per).mean(axis=1)
    return mean, e.support.reshape(per).mean(axis=1), depth.reshape(per).mean(axis=1), layer


def tile_nodes(xg: NDArray[np.int64], yg: NDArray[np.int64], level: int) -> tuple[NDArray[np.float64], ...]:
    """x and y of each tile's 3 × 3 nodes (corners, edge middles, centre), tile by tile."""
    u, v = np.meshgrid([0.0, 0.5, 1.0], [0.0, 0.5, 1.0])
    return ((xg[:, None] + level * u.ravel()[None, :]).ravel(), (yg[:, None] + level * v.ravel()[None, :]).ravel())


def tile_lattice(
    db: Database, version: str, level: int, xg: NDArray[np.int64], yg: NDArray[np.int64]
) -> NodeLattice:
    """The version's stored points around the tiles, on the level's node lattice: far enough
    beyond them for the filters' two-sided relief (read once, for surfaces and typing)."""
    grow = REACH_TILES * level + 2 * level
    bbox = (float(xg.min() - grow), float(yg.min() - grow), float(xg.max() + grow), float(yg.max() + grow))
    x, y, z, _ = db.points(version, level=level, bbox=bbox, ordered=False)
    return node_lattice(x, y, z, level)


def _ranges(n: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Lowest and highest stored node along the first axis (+inf and −inf where none)."""
    lo, hi = nan_extreme(n, -1.0, axis=0), nan_extreme(n, 1.0, axis=0)
    none = np.isnan(lo)
    return np.where(none, np.inf, lo), np.where(none, -np.inf, hi)


def may_move(na: NDArray[np.float64], nb: NDArray[np.float64], lod: NDArray[np.float64]) -> NDArray[np.intp]:
    """Per tile, at most how many of its 3 × 3 nodes can move beyond its ``lod`` (stored nodes
    ``na``, ``nb`` of the two versions), without rebuilding the surfaces.

    The rebuilt surface keeps stored corners as they are; an edge middle is a line between
    stored nodes of its own edge, and the centre a convex mix of the tile's stored nodes.
    So a corner counts when it moved, an edge middle when the ranges of its edge's stored
    nodes allow it, and the centre when the tile's ranges do.
    """
    if len(na) == 0:
        return np.zeros(0, np.intp)
    last = SUBGRID - 1
    # Tiles last: every reduction below runs across whole rows of tiles.
    a, b = (np.ascontiguousarray(np.moveaxis(n, 0, -1)) for n in (na, nb))
    with np.errstate(invalid="ignore"):
        count = (np.abs(b[::last, ::last] - a[::last, ::last]) > lod).sum(axis=(0, 1))  # NaN: never
        for edge in ((0, slice(None)), (last, slice(None)), (slice(None), 0), (slice(None), last)):
            (lo_a, hi_a), (lo_b, hi_b) = _ranges(a[edge]), _ranges(b[edge])
            count += np.maximum(hi_b - lo_a, hi_a - lo_b) > lod  # inf − inf (no stored node): not counted
        (lo_a, hi_a), (lo_b, hi_b) = _ranges(a.reshape(-1, len(na))), _ranges(b.reshape(-1, len(nb)))
        count += np.maximum(hi_b - lo_a, hi_a - lo_b) > lod
    return np.asarray(count, np.intp)


def curved_lod(
    lod: NDArray[np.float64], surfaces: NDArray[np.float64], reach: NDArray[np.float64], *, spacing: float
) -> NDArray[np.float64]:
    """Each tile's ``lod`` grown by the relief that each version's surface may miss between its
    ground returns (:func:`tdb.evidence.missed_relief`), added in quadrature.

    The ground's curvature in a tile is the largest second difference of its 3 × 3 nodes
    (``spacing`` m apart), along rows or columns, in either version's rebuilt ``surfaces``
    (2, tiles, 9): a survey whose returns missed a ditch's bottom bridges it, so the
    curvature the other survey shows counts for both. ``reach`` (2, tiles): how far each
    version's nodes lie from its ground returns (RMS, m)."""
    z = surfaces.reshape(*surfaces.shape[:2], 3, 3)
    with np.errstate(invalid="ignore"):
        across = np.abs(z[..., 0, :] - 2 * z[..., 1, :] + z[..., 2, :])
        along = np.abs(z[..., :, 0] - 2 * z[..., :, 1] + z[..., :, 2])
        bends = np.concatenate([across, along], axis=-1)
        curvature = np.nan_to_num(nan_extreme(bends, 1.0, axis=(0, 2))) / spacing**2
    missed = missed_relief(curvature[None, :], reach)
    return np.sqrt(lod**2 + np.square(missed).sum(axis=0))


def rebuilt_surface(nodes: NDArray[np.float64]) -> NDArray[np.float64]:
    """Heights of the line rebuild (:mod:`tdb.surface`) at the 3 × 3 nodes of each tile (NaN: no data)."""
    mid = (SUBGRID - 1) // 2
    cells = np.ravel_multi_index(
        np.meshgrid(np.arange(0, SUBGRID, mid), np.arange(0, SUBGRID, mid), indexing="ij"), (SUBGRID, SUBGRID)
    )
    return line_rebuild_at(nodes, cells.ravel())


@dataclass(frozen=True)
class MovingTiles:
    """The tiles both versions hold at one level, their stored points and the LoD."""

    xg: NDArray[np.int64]
    yg: NDArray[np.int64]
    before: NodeLattice
    after: NodeLattice
    judged: TileJudgement

    def moved(
        self, which: NDArray[np.intp]
    ) -> tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
        """The tiles ``which`` that can move (indices), the height change at their 3 × 3 nodes,
        their LoD grown by the relief the surfaces may miss between returns (:func:`curved_lod`),
        and whether each moved: at least three of its nine nodes beyond it, since one node
        alone is often an interpolation difference between the two sets of kept points."""
        which = which[self.judged.seen[which]]
        xg, yg = self.xg[which], self.yg[which]
        na, nb = self.before.tile_nodes(xg, yg), self.after.tile_nodes(xg, yg)
        keep = np.flatnonzero(may_move(na, nb, self.lod[which]) >= 3)
        surfaces = rebuilt_surface(np.concatenate([na[keep], nb[keep]]))
        dz = supported_change(surfaces[len(keep) :] - surfaces[: len(keep)], self.judged.depth[:, which[keep]])
        lod = curved_lod(
            self.lod[which[keep]],
            surfaces.reshape(2, len(keep), 9),
            self.judged.reach[:, which[keep]],
            spacing=self.before.spacing * (SUBGRID - 1) / 2,
        )
        with np.errstate(invalid="ignore"):
            moved = (np.abs(dz) > lod[:, None]).sum(axis=1) >= 3
        return which[keep], dz, lod, moved

    @property
    def lod(self) -> NDArray[np.float64]:
        return self.judged.lod


def split_keys(
    kx: NDArray[np.int64], ky: NDArray[np.int64], factor: int
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Keys of the factor × factor finer tiles making up each tile, tile by tile."""
    d = np.arange(factor)
    shape = (len(kx), factor, factor)
    fx = np.broadcast_to(kx[:, None, None] * factor + d[None, None, :], shape)
    fy = np.broadcast_to(ky[:, None, None] * factor + d[None, :, None], shape)
    return fx.ravel(), fy.ravel()
