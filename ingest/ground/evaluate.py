"""Filter accuracy as the ISPRS filter test reports it."""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class Accuracy:
    """Type I (ground rejected), Type II (object accepted), total error and Cohen's kappa, in %."""

    type1: float
    type2: float
    total: float
    kappa: float
    n: int

    def as_dict(self) -> dict[str, float]:
        return asdict(self)


def accuracy(truth_ground: NDArray[np.bool_], predicted_ground: NDArray[np.bool_]) -> Accuracy:
    """Compare a predicted ground mask with the reference one."""
    t = np.asarray(truth_ground, bool)
    p = np.asarray(predicted_ground, bool)
    n = len(t)
    a = float((t & p).sum())  # ground kept
    b = float((t & ~p).sum())  # ground rejected (Type I)
    c = float((~t & p).sum())  # object accepted (Type II)
    d = float((~t & ~p).sum())
    observed = (a + d) / n
    expected = ((a + b) * (a + c) + (c + d) * (b + d)) / (n * n)
    kappa = (observed - expected) / (1 - expected) if expected < 1 else 1.0
    return Accuracy(
        type1=100 * b / max(a + b, 1),
        type2=100 * c / max(c + d, 1),
        total=100 * (b + c) / n,
        kappa=100 * kappa,
        n=n,
    )
