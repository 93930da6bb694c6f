"""Ground evidence: per 2 m tile, how far its surface rests on ground returns.

A dense model is a surface everywhere, but it is measured only where the ground was
seen. Under dense cover it bridges the gap between the nearest ground returns, and
where a ground filter took low vegetation for the ground its returns stand above
the ground seen through it. Two figures per tile say how much to trust it:

- ``support``: the share of the tile's 3 × 3 nodes with a ground return close by
  (within :data:`SUPPORT_SPACINGS` pulse spacings);
- ``sigma``: the standard uncertainty (m) of the surface in the tile: how far its
  ground returns stand above the lower envelope of their neighbourhoods (the
  local surface carried along), and, where a node is farther
  from a return than that, the relief the terrain may hide across the gap
  (:data:`GAP_SLOPE` per metre);
- ``depth``: how far the surface stands above the tile's ground returns (the depth a
  fifth of them reach, :func:`ingest.evidence.tile_depth`). Where a
  filter took low vegetation's top for the ground beside ground seen through it, the
  surface runs between the two and the ground seen lies under it: that survey saw the
  lower level, so a rise of the surface there is not evidence that the ground rose.
- ``over_low``, ``over_high``: the lowest and highest of the tile's returns that the filter did
  not take for ground, over its surface (those from :data:`OVER` to :data:`OVER_CAP` up). Where one survey took
  for ground what another saw and did not (a low wall, a thicket's top), the other's returns
  stand where the first's surface is: a change between them is one of what was taken for
  ground, not of the ground (:mod:`queries.changes`).
- ``pulses``, ``ground_share``: the tile's pulses per m² (their last returns), and the share of
  them that the filter took for ground. Under a closed canopy most pulses end in the crowns or
  the understorey and few reach the ground. A dense survey still holds enough of those for its
  filter to find the ground among the understorey's tops; a sparse one may not, and its filter
  then takes the understorey's top for the ground, which nothing else in the tile shows (its
  few returns taken for ground lie on one rough level). Where most pulses did not reach what was
  taken for ground, and those that did are fewer than one per square metre, that survey saw the
  cover, not the ground (:mod:`queries.changes`).
- ``reach``: how far the tile's 3 × 3 nodes lie from the nearest ground return (RMS, m). On
  curved ground (a ditch, a bank's rim) a surface made between returns misses relief that grows
  with the square of that distance (:func:`missed_relief`), so two surveys cut a narrow ditch's
  section at different depths where neither holds a return at its bottom.
- ``layer``: how thick a layer taken for ground the tile lies in: the median lift of the
  tiles around it (:func:`ingest.evidence.tile_layer`). Under a closed canopy few returns
  reach the ground, and a filter takes the understorey for it: the ground seen is then too
  small a share of a tile's returns for its depth to show, but every tile's highest return
  stands over the ground seen nearby by about the understorey's height. A step lifts the
  tiles along its edge alone, a line the median over an area passes over.

``standing`` is the more of depth and layer: how far the surface may stand above the
ground its survey saw.

A change between two versions is claimed only where both surfaces are seen well
enough (:data:`MIN_SUPPORT`), beyond a level of detection grown by the relief both
versions' gaps may hide (:mod:`queries.changes`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tdb.tiles import TileIndex

LEVEL = 2  # m: evidence is kept for the finest tiles
SUPPORT_SPACINGS = 1.5  # open ground has a return within this many pulse spacings of every node
GAP_SLOPE = 0.1  # rise/run the terrain may take unseen across a gap in the ground returns
MIN_SUPPORT = 0.5  # a change needs half a tile's nodes seen in each version
DEEP = 0.1  # m: a surface this far over its ground returns rests partly on what was taken for ground
OVER = 0.1  # m: returns not taken for ground this far over the surface stand on it (not noise in it)
OVER_CAP = 3.0  # m: what stands higher than a wall or a thicket, no filter takes for ground
# A tile is under cover where its survey took for ground less than COVERED of its pulses (most
# ended in the cover) and fewer than GROUNDED of them per m²: a ground filter rests its surface on
# the lowest return of each square metre (its seed cells), which is the understorey's top wherever
# no pulse reached the ground there.
COVERED = 0.5
GROUNDED = 1.0  # pulses taken for ground per m²
# A line between returns misses κr²/2 of the relief of ground of curvature κ at a node r from the
# nearer: a 2 m ditch 1 m deep (κ ≈ 2 /m) holds returns 1.15 m apart at 0.75 pulses/m², and its
# bottom may lie 0.6 m from the nearest, so each survey's surface cuts it at another depth.
MISSED = 0.5
# A change is claimed only where each survey holds at least this many ground returns in the region:
# a region's mean change over fewer rests on where a handful of returns happened to fall.
MIN_RETURNS = 16


@dataclass(frozen=True)
class TileEvidence:
    """Ground evidence of 2 m tiles keyed by their lower-left corners ``xg``, ``yg`` (m)."""

    xg: NDArray[np.int64]
    yg: NDArray[np.int64]
    lift: NDArray[np.float32]  # m: RMS height of the tile's returns over their lower envelope
    gap: NDArray[np.float32]  # m: mean distance of its nodes beyond the support radius
    depth: NDArray[np.float32]  # m: how far its surface stands above its ground returns
    layer: NDArray[np.float32]  # m: the median lift of the tiles around it
    # m: the lowest and highest of its returns not taken for ground, over its surface (NaN: none)
    over_low: NDArray[np.float32]
    over_high: NDArray[np.float32]
    pulses: NDArray[np.float32]  # its pulses (last returns) per m² (0: none; NaN: not kept when stored)
    ground_share: NDArray[np.float32]  # the share of them taken for ground (NaN: none)
    reach: NDArray[np.float32]  # m: RMS distance of its nodes from the nearest ground return
    support: NDArray[np.float32]  # share of its nodes with a ground return within the radius

    # support last: a stored tile is held where it is set (:func:`tdb.blocks.evidence_from_blocks`);
    # a field added later goes before it, and reads NaN from pages written before it was
    FIELDS = (
        "lift",
        "gap",
        "depth",
        "layer",
        "over_low",
        "over_high",
        "pulses",
        "ground_share",
        "reach",
        "support",
    )

    @classmethod
    def empty(cls) -> TileEvidence:
        none = np.empty(0, np.float32)
        return cls(np.empty(0, np.int64), np.empty(0, np.int64), *([none] * len(cls.FIELDS)))

    def __len__(self) -> int:
        return len(self.xg)

    @property
    def sigma(self) -> NDArray[np.float64]:
        """Standard uncertainty (m) of each tile's surface: its lift, and the relief a gap may hide."""
        return np.sqrt(self.lift.astype(float) ** 2 + (GAP_SLOPE * self.gap.astype(float)) ** 2)

    def take(self, index: NDArray[np.intp] | NDArray[np.bool_]) -> TileEvidence:
        return TileEvidence(self.xg[index], self.yg[index], *(getattr(self, f)[index] for f in self.FIELDS))

    def at(self, xg: NDArray[np.int64], yg: NDArray[np.int64]) -> TileEvidence:
        """The evidence of the tiles ``xg``, ``yg``, in their order: NaN (support 0) where none is held."""
        xg, yg = np.asarray(xg, np.int64), np.asarray(yg, np.int64)
        fields = [np.full(len(xg), np.nan, np.float32) for _ in self.FIELDS]
        fields[-1][:] = 0.0
        if len(self) and len(xg):
            at = TileIndex(self.xg // LEVEL, self.yg // LEVEL).find(xg // LEVEL, yg // LEVEL)
            hit = at >= 0
            for out, name in zip(fields, self.FIELDS):
                out[hit] = getattr(self, name)[at[hit]]
        return TileEvidence(xg, yg, *fields)

    @property
    def standing(self) -> NDArray[np.float64]:
        """How far (m) each tile's surface may stand above the ground its survey saw: the more of
        its depth and its layer (0 where neither is held)."""
        return np.maximum(np.nan_to_num(self.depth.astype(float)), np.nan_to_num(self.layer.astype(float)))

    @property
    def deep(self) -> NDArray[np.bool_]:
        """Whether each tile's surface stands at least :data:`DEEP` over its ground returns."""
        return self.standing >= DEEP

    @property
    def covered(self) -> NDArray[np.bool_]:
        """Whether each tile is under cover (:data:`COVERED`, :data:`GROUNDED`; False where its
        pulses are not held)."""
        share = self.ground_share.astype(float)
        return under_cover(share, self.pulses.astype(float) * share)

    def supported_share(self) -> float:
        """Share of the tiles whose surface is seen well enough for a change to be claimed."""
        return float((self.support >= MIN_SUPPORT).mean()) if len(self) else 0.0


def under_cover(share: Any, grounded: Any) -> Any:
    """Whether what took ``share`` of its pulses for ground, ``grounded`` of them per m², is under
    cover (:data:`COVERED`, :data:`GROUNDED`): tiles or regions, arrays or numbers; NaN is not."""
    with np.errstate(invalid="ignore"):
        return np.logical_and(np.less(share, COVERED), np.less(grounded, GROUNDED))


def missed_relief(curvature: NDArray[np.float64], reach: NDArray[np.float64]) -> NDArray[np.float64]:
    """The height (m) a surface interpolated linearly between ground returns misses on ground of
    ``curvature`` (1/m) at a node ``reach`` m from the nearest return: between two returns 2r
    apart the line misses κ·x·(2r − x)/2 at x, so at least κr²/2 at a node r from the nearer
    one, its whole at the midpoint (× :data:`MISSED` / ½)."""
    return MISSED * curvature * np.square(reach)


def too_few_returns(returns: Any) -> Any:
    """Whether ``returns`` ground returns (a number or an array) are too few for a change to rest on
    (:data:`MIN_RETURNS`)."""
    return np.less(returns, MIN_RETURNS)


def supported_change(dz: NDArray[np.float64], depth: NDArray[np.float64]) -> NDArray[np.float64]:
    """The height change at each tile's nodes (``dz``, tiles × nodes) that both surveys' ground
    evidence supports: a rise less the later surface's depth over its ground returns, a
    fall less the earlier one's (``depth``, 2 × tiles), never past zero.

    The survey whose surface stands higher saw ground returns at the lower level through what
    its filter took for ground (low vegetation's top): the ground it saw did not move. A mound
    raised or a ditch dug leaves no return under the higher surface."""
    with np.errstate(invalid="ignore"):
        rise = np.maximum(dz - depth[1][:, None], 0.0)
        fall = np.minimum(dz + depth[0][:, None], 0.0)
        return np.where(dz > 0, rise, fall)
