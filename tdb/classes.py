"""Point classes a survey marks as unusable, which no ground filter may take.

ASPRS reserves class 7 for low points (noise) and 18 for high noise: the producer
has already judged them wrong, and a low noise point is exactly what a ground
filter would otherwise pick. National schemes add their own in the user range
(64–255), e.g. IGN LiDAR HD's 65 "artefacts"; users name those themselves.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
from numpy.typing import NDArray

from tdb.errors import OptionError

NOISE = (7, 18)  # ASPRS low point (noise), high noise


def parse_classes(text: str | Iterable[int]) -> tuple[int, ...]:
    """``"7,18,65"`` (or integers) → sorted unique class codes; ``""`` or ``"none"`` → none.

    Raises
    ------
    OptionError
        If an entry is not an integer from 0 to 255.
    """
    if isinstance(text, str):
        parts = [p.strip() for p in text.split(",")] if text.strip() else []
        if "" in parts:
            raise OptionError(f"{text!r}: an empty entry between commas; expected class codes like 7,18")
        if parts == ["none"]:
            return ()
        try:
            codes = [int(p) for p in parts]
        except ValueError:
            raise OptionError(f"{text!r}: expected class codes like 7,18 (or 'none')") from None
    else:
        codes = [int(c) for c in text]
    bad = [c for c in codes if not 0 <= c <= 255]
    if bad:
        raise OptionError(f"class codes run from 0 to 255, not {bad[0]}")
    return tuple(sorted(set(codes)))


def excluded(classification: NDArray[np.uint8], classes: Iterable[int]) -> NDArray[np.bool_]:
    """Mask of the points whose class is one of ``classes``."""
    codes = np.fromiter(classes, np.int64)
    if len(codes) == 0:
        return np.zeros(len(classification), bool)
    return np.isin(classification, codes)


def user_classes(classification: NDArray[np.uint8], exclude: Iterable[int]) -> dict[str, int]:
    """Points per class of the user range (64–255) that ``exclude`` keeps: a scheme the ASPRS
    codes do not define, whose meaning only the producer knows (``{"65": 539}``)."""
    codes, counts = np.unique(classification[classification >= 64], return_counts=True)
    skip = set(exclude)
    return {str(int(c)): int(n) for c, n in zip(codes, counts) if int(c) not in skip}
