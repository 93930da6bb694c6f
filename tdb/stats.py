"""What ingest measured of a survey, stored with its version: typed records and their JSON form.

The JSON keys are flat (``tiles_2m``, ``rmse_m`` …) so that databases written before these
records existed read back unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from tdb.tiles import LEVELS


@dataclass(frozen=True)
class ReductionStats:
    """How far the dense model was reduced, and the error of the surface rebuilt from what was kept.

    ``rmse_m`` and ``max_error_m`` are None where too few points were kept to rebuild a surface.
    """

    dense_posts: int
    kept_points: int
    kept_level2: int
    reduction_pct: float
    rmse_m: float | None = None
    max_error_m: float | None = None
    tiles: dict[int, int] = field(default_factory=dict)  # tiles per level
    no_data: dict[int, int] = field(default_factory=dict)  # tiles without a category per level


@dataclass(frozen=True)
class VersionStats:
    """One stored survey's figures: its points, its ground, and its reduction."""

    reduction: ReductionStats
    points: int = 0
    ground_points: int = 0
    excluded_points: int = 0  # of the excluded classes, or flagged withheld
    kept_user_classes: dict[int, int] = field(default_factory=dict)  # points of producer classes 64–255
    noise_m: float | None = None  # the ground's measured vertical noise
    flat_threshold_m: float | None = None
    bounds: tuple[float, float, float, float] | None = None  # x0, y0, x1, y1 of the dense model
    seen_pct: float | None = None  # 2 m tiles whose surface rests on ground returns (tdb.evidence)
    sigma_m: float | None = None  # the median standard uncertainty of a 2 m tile's surface
    deep_pct: float | None = None  # 2 m tiles whose surface stands over its ground returns (tdb.evidence.DEEP)
    covered_pct: float | None = None  # 2 m tiles under cover (tdb.evidence.TileEvidence.covered)

    def to_json(self) -> dict[str, Any]:
        """The flat JSON object stored in ``versions.stats``."""
        r = self.reduction
        out: dict[str, Any] = {
            "dense_posts": r.dense_posts,
            "kept_points": r.kept_points,
            "kept_level2": r.kept_level2,
            "reduction_pct": r.reduction_pct,
        }
        if r.rmse_m is not None:
            out["rmse_m"], out["max_error_m"] = r.rmse_m, r.max_error_m
        for level in r.tiles:
            out[f"tiles_{level}m"] = r.tiles[level]
            out[f"no_data_{level}m"] = r.no_data.get(level, 0)
        out.update(
            points=self.points,
            ground_points=self.ground_points,
            excluded_points=self.excluded_points,
            kept_user_classes={str(c): n for c, n in self.kept_user_classes.items()},
            noise_m=self.noise_m,
            flat_threshold_m=self.flat_threshold_m,
            bounds=None if self.bounds is None else list(self.bounds),
            seen_pct=self.seen_pct,
            sigma_m=self.sigma_m,
            deep_pct=self.deep_pct,
            covered_pct=self.covered_pct,
        )
        return out

    @classmethod
    def from_json(cls, doc: dict[str, Any]) -> VersionStats:
        """Read the stored JSON object back; keys a version lacks take their defaults."""
        reduction = ReductionStats(
            dense_posts=int(doc.get("dense_posts", 0)),
            kept_points=int(doc.get("kept_points", 0)),
            kept_level2=int(doc.get("kept_level2", 0)),
            reduction_pct=float(doc.get("reduction_pct", 0.0)),
            rmse_m=_float(doc.get("rmse_m")),
            max_error_m=_float(doc.get("max_error_m")),
            tiles={lv: int(doc[f"tiles_{lv}m"]) for lv in LEVELS if f"tiles_{lv}m" in doc},
            no_data={lv: int(doc[f"no_data_{lv}m"]) for lv in LEVELS if f"no_data_{lv}m" in doc},
        )
        bounds = doc.get("bounds")
        return cls(
            reduction=reduction,
            points=int(doc.get("points", 0)),
            ground_points=int(doc.get("ground_points", 0)),
            excluded_points=int(doc.get("excluded_points", 0)),
            kept_user_classes={int(c): int(n) for c, n in (doc.get("kept_user_classes") or {}).items()},
            noise_m=_float(doc.get("noise_m")),
            flat_threshold_m=_float(doc.get("flat_threshold_m")),
            bounds=None if bounds is None else _box(bounds),
            seen_pct=_float(doc.get("seen_pct")),
            sigma_m=_float(doc.get("sigma_m")),
            deep_pct=_float(doc.get("deep_pct")),
            covered_pct=_float(doc.get("covered_pct")),
        )


def _box(values: Any) -> tuple[float, float, float, float]:
    x0, y0, x1, y1 = (float(v) for v in values)
    return (x0, y0, x1, y1)


def _float(value: Any) -> float | None:
    return None if value is None else float(value)
