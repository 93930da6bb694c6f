"""Point pages: the kept points of a version, one BLOB per 256 m block.

A page holds a block's points as four packed columns. Since schema 6 they follow an 8-byte tag:
x and y as float32 offsets from the block's south-west corner, z as an int32 count of 2⁻¹⁴ m,
and the level mask n as uint8: 13 bytes a point where absolute float64 took 25, which halves
what an area read fetches and decodes. A point is stored to within 8 µm horizontally (half the
float32 spacing below 256 m) and 31 µm vertically, finer than any survey's stored scale, and
as a function of the point alone: a page merged from parts holds exactly what one written whole
holds.

Pages written before (absolute float64 x, y, z, then uint8 n) are still read: no such page
starts with the tag, whose first eight bytes read as a float64 x near 10⁻²⁹⁶ m.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tdb.blocks import group_starts
from tdb.errors import InputError

POINT_BLOCK = 256.0  # m: a power of two, so a block holds bx * side <= x < (bx + 1) * side exactly
TAG = b"\x89tdbp\x01\x02\x02"  # the high byte 0x02 makes it a float64 of ~1e-296, no coordinate
Z_UNIT = 2.0**-14  # m: heights as whole counts of it, within ±131 km
OLD_POINT_BYTES = 25  # x, y, z float64 and n uint8
POINT_BYTES = 13  # x, y float32 offsets, z int32 and n uint8


@dataclass(frozen=True)
class Page:
    """A decoded page: x, y, z as stored, each placed by its (offset, unit) in ``placing``
    (a coordinate is stored × unit + offset), and the level masks ``n``."""

    x: NDArray[Any]
    y: NDArray[Any]
    z: NDArray[Any]
    n: NDArray[np.uint8]
    placing: tuple[tuple[float, float], tuple[float, float], tuple[float, float]]

    def stored(self) -> tuple[NDArray[Any], NDArray[Any], NDArray[Any]]:
        return self.x, self.y, self.z

    def absolute(self) -> list[NDArray[np.float64]]:
        return [c.astype(np.float64) * unit + offset for c, (offset, unit) in zip(self.stored(), self.placing)]


def point_blocks(
    x: NDArray[np.float64], y: NDArray[np.float64], z: NDArray[np.float64], n: NDArray[np.uint8]
) -> Iterator[tuple[int, int, bytes]]:
    """(bx, by, page) per 256 m block that holds points: the tag, then x, y offsets as float32,
    z in counts of ``Z_UNIT`` as int32 and n as uint8, packed.

    Raises
    ------
    InputError
        If a height lies beyond ±131 km (not a height in metres).
    """
    highest = float(np.abs(z).max()) if len(z) else 0.0
    if not highest < 2**31 * Z_UNIT:
        raise InputError(f"heights up to {highest:.6g} m: not heights in metres")
    bx = np.floor(x / POINT_BLOCK).astype(np.int64)
    by = np.floor(y / POINT_BLOCK).astype(np.int64)
    order = np.lexsort((by, bx))
    bxs, bys = bx[order], by[order]
    starts = group_starts(bxs, bys)
    for s, e in zip(starts, np.r_[starts[1:], len(order)]):
        sel = order[s:e]
        ox, oy = float(bxs[s]) * POINT_BLOCK, float(bys[s]) * POINT_BLOCK
        columns = [
            (x[sel] - ox).astype("<f4"),
            (y[sel] - oy).astype("<f4"),
            np.rint(z[sel] / Z_UNIT).astype("<i4"),
            n[sel].astype(np.uint8),
        ]
        yield int(bxs[s]), int(bys[s]), b"".join([TAG, *(c.tobytes() for c in columns)])


def decoded(bx: int, by: int, blob: bytes) -> Page:
    """The columns of a page, of either layout, without copying them."""
    if blob[: len(TAG)] == TAG:
        m = (len(blob) - len(TAG)) // POINT_BYTES
        xy = np.frombuffer(blob, "<f4", count=2 * m, offset=len(TAG))
        z = np.frombuffer(blob, "<i4", count=m, offset=len(TAG) + 8 * m)
        n = np.frombuffer(blob, np.uint8, offset=len(TAG) + 12 * m)
        return Page(xy[:m], xy[m:], z, n, ((bx * POINT_BLOCK, 1.0), (by * POINT_BLOCK, 1.0), (0.0, Z_UNIT)))
    m = len(blob) // OLD_POINT_BYTES
    f = np.frombuffer(blob, "<f8", count=3 * m)
    n = np.frombuffer(blob, np.uint8, offset=24 * m)
    return Page(f[:m], f[m : 2 * m], f[2 * m :], n, ((0.0, 1.0), (0.0, 1.0), (0.0, 1.0)))


def points_from_blocks(
    blocks: list[tuple[int, int, bytes]], bbox: tuple[float, float, float, float], *, mask: int
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.uint8]]:
    """(x, y, z, n) of the points of ``blocks`` (bx, by, page) inside ``bbox`` whose level mask
    has a bit of ``mask``.

    The points to keep are found page by page on the stored offsets, then written once into
    arrays of the final size: no page is copied twice.
    """
    x0, y0, x1, y1 = bbox
    picked: list[tuple[Page, NDArray[np.intp] | None]] = []
    for bx, by, blob in blocks:
        page = decoded(bx, by, blob)
        (ox, _), (oy, _), _ = page.placing
        keep = (page.n & mask) > 0
        # only where the box's edge cuts a block need its points be placed; the bounds are numpy
        # float64 scalars so that float32 offsets are compared in float64, as they are returned
        if not (x0 <= bx * POINT_BLOCK and (bx + 1) * POINT_BLOCK <= x1):
            keep &= (page.x >= np.float64(x0 - ox)) & (page.x <= np.float64(x1 - ox))
        if not (y0 <= by * POINT_BLOCK and (by + 1) * POINT_BLOCK <= y1):
            keep &= (page.y >= np.float64(y0 - oy)) & (page.y <= np.float64(y1 - oy))
        picked.append((page, None if keep.all() else np.flatnonzero(keep)))
    total = sum(len(p.n) if pick is None else len(pick) for p, pick in picked)
    out = np.empty(total), np.empty(total), np.empty(total)
    n_out = np.empty(total, np.uint8)
    start = 0
    for page, pick in picked:
        stop = start + (len(page.n) if pick is None else len(pick))
        for column, stored, (offset, unit) in zip(out, page.stored(), page.placing):
            part = column[start:stop]
            part[:] = stored if pick is None else stored[pick]
            if unit != 1.0:
                part *= unit
            if offset:
                part += offset
        n_out[start:stop] = page.n if pick is None else page.n[pick]
        start = stop
    return out[0], out[1], out[2], n_out


def merge_point_pages(block: tuple[int, int], old: bytes, new: bytes) -> bytes:
    """The page of ``block`` (bx, by) holding the points of two of its pages, written apart."""
    pages = [decoded(*block, b) for b in (old, new)]
    x, y, z = (np.concatenate(c) for c in zip(*(p.absolute() for p in pages)))
    ((_, _, blob),) = point_blocks(x, y, z, np.concatenate([p.n for p in pages]))
    return blob
