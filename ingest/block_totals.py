"""What one block of a blocked ingest contributes, and the version's figures summed block by block.

The figures of a version (:class:`tdb.stats.VersionStats`) are sums, weighted means and medians
over its blocks. They are gathered as each block is stored, so no figure needs the whole survey
in memory: the median uncertainty of a tile is read from a histogram of millimetres (the figure
is stored rounded to the millimetre).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from tdb.evidence import MIN_SUPPORT, TileEvidence
from tdb.objects import Building, Tree
from tdb.stats import ReductionStats, VersionStats
from tdb.tiles import level_bit

SIGMA_BINS = 10_000  # mm; larger uncertainties count in the last bin


@dataclass(frozen=True)
class BlockResult:
    """What one block contributes: its tiles per level, its kept points and its figures."""

    levels: dict[int, tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.uint8]]]
    points: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.uint8]]
    reduction: ReductionStats
    points_read: int
    ground: int
    excluded: int
    noise: float
    flat_threshold: float
    evidence: TileEvidence
    trees: list[Tree]
    buildings: list[Building]
    echo_test: bool  # whether the block's returns told double echoes apart (see ingest.objects)
    peak_mib: float = 0.0  # the peak memory of the process that modelled it, when it was done


@dataclass
class Totals:
    """The version's figures over the blocks added so far."""

    blocks: int = 0
    posts: int = 0
    kept: int = 0
    kept_finest: int = 0
    squared_error: float = 0.0  # Σ rmse² × posts over the blocks with a figure
    weighed_posts: int = 0
    max_error: float = 0.0
    tiles: dict[int, int] = field(default_factory=dict)
    no_data: dict[int, int] = field(default_factory=dict)
    points: int = 0
    ground: int = 0
    excluded: int = 0
    noise_sum: float = 0.0  # Σ noise × points read
    thresholds: list[float] = field(default_factory=list)
    evidence_tiles: int = 0
    supported: int = 0
    deep: int = 0
    covered: int = 0
    sigma_mm: NDArray[np.int64] = field(default_factory=lambda: np.zeros(SIGMA_BINS + 1, np.int64))
    echo_test: bool = False
    peak_mib: float = 0.0  # the largest of the blocks' modelling processes

    def add(self, r: BlockResult) -> None:
        red = r.reduction
        self.blocks += 1
        self.posts += red.dense_posts
        self.kept += len(r.points[0])
        finest = min(r.levels)
        self.kept_finest += int(((r.points[3] & level_bit(finest)) > 0).sum())
        if red.rmse_m is not None:
            self.squared_error += red.rmse_m**2 * red.dense_posts
            self.weighed_posts += red.dense_posts
        self.max_error = max(self.max_error, red.max_error_m or 0.0)
        for lv, (xg, _, _) in r.levels.items():
            self.tiles[lv] = self.tiles.get(lv, 0) + len(xg)
            self.no_data[lv] = self.no_data.get(lv, 0) + red.no_data.get(lv, 0)
        self.points += r.points_read
        self.ground += r.ground
        self.excluded += r.excluded
        self.noise_sum += r.noise * r.points_read
        self.thresholds.append(r.flat_threshold)
        self.evidence_tiles += len(r.evidence)
        self.supported += int((r.evidence.support >= MIN_SUPPORT).sum())
        self.deep += int(r.evidence.deep.sum())
        self.covered += int(r.evidence.covered.sum())
        mm = np.minimum(np.round(r.evidence.sigma * 1000), SIGMA_BINS).astype(np.int64)
        self.sigma_mm += np.bincount(mm, minlength=SIGMA_BINS + 1)
        self.echo_test |= r.echo_test
        self.peak_mib = max(self.peak_mib, r.peak_mib)

    @property
    def flat_threshold(self) -> float:
        return float(np.median(self.thresholds))

    def reduction(self) -> ReductionStats:
        rmse = np.sqrt(self.squared_error / self.weighed_posts) if self.weighed_posts else None
        return ReductionStats(
            dense_posts=self.posts,
            kept_points=self.kept,
            kept_level2=self.kept_finest,
            reduction_pct=round(100.0 * (1 - self.kept_finest / max(self.posts, 1)), 2),
            rmse_m=None if rmse is None else round(float(rmse), 4),
            max_error_m=self.max_error,
            tiles=dict(self.tiles),
            no_data=dict(self.no_data),
        )

    def stats(self, bounds: tuple[float, float, float, float]) -> VersionStats:
        return VersionStats(
            reduction=self.reduction(),
            points=self.points,
            ground_points=self.ground,
            excluded_points=self.excluded,
            noise_m=round(self.noise_sum / max(self.points, 1), 4),
            flat_threshold_m=round(self.flat_threshold, 3),
            bounds=bounds,
            seen_pct=self._pct(self.supported),
            sigma_m=self._median_sigma(),
            deep_pct=self._pct(self.deep),
            covered_pct=self._pct(self.covered),
        )

    def _pct(self, tiles: int) -> float | None:
        """``tiles`` as a share (%) of the 2 m tiles holding evidence."""
        return round(100 * tiles / self.evidence_tiles, 1) if self.evidence_tiles else None

    def _median_sigma(self) -> float | None:
        if not self.evidence_tiles:
            return None
        # np.median of an even count averages the two middle values: so do the bins
        cum = np.cumsum(self.sigma_mm)
        lo = int(np.searchsorted(cum, (self.evidence_tiles - 1) // 2 + 1))
        hi = int(np.searchsorted(cum, self.evidence_tiles // 2 + 1))
        return round((lo + hi) / 2000, 3)
