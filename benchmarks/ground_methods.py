"""The ground filters compared in the benchmarks, by name."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from ingest.ground import classify_ground


def _ours(method: str) -> Callable[[NDArray[np.float64]], NDArray[np.bool_]]:
    return lambda xyz: classify_ground(xyz, method=method)


def methods() -> dict[str, Callable[[NDArray[np.float64]], NDArray[np.bool_]]]:
    from benchmarks import peers

    return {
        "tdb auto": _ours("auto"),
        "tdb sohn": _ours("sohn"),
        "tdb contour": _ours("contour"),
        "pysmrf": peers.smrf,
        "CSF": peers.csf,
    }
