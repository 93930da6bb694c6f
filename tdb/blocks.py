"""Area pages: the tiles and points of a version cut into square blocks stored as BLOBs.

The row tables (``tdb``, ``c2`` … ``c16``) answer SQL; an area of interest of a
square kilometre is 250 000 tiles and as many points at the 2 m level, and
stepping through that many rows costs a second in Python. The same data cut into
blocks (a uint8 raster of codes per block of 128 × 128 tiles; the points of each
256 m block as packed arrays, :mod:`tdb.point_pages`) is read as a few dozen BLOBs
and decoded by numpy. Writes keep both in the same transaction.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tdb.categories import NO_DATA

TILES_PER_BLOCK = 128
ABSENT = 254  # no tile stored there; not a category code, and unlike NO_DATA (a stored tile without data)
assert ABSENT != NO_DATA


def group_starts(a: NDArray[np.int64], b: NDArray[np.int64]) -> NDArray[np.intp]:
    """Where each run of equal (a, b) starts, for arrays sorted by (a, b)."""
    if len(a) == 0:
        return np.empty(0, np.intp)
    return np.flatnonzero(np.r_[True, (a[1:] != a[:-1]) | (b[1:] != b[:-1])])


def _raster_blocks(
    xg: NDArray[np.int64], yg: NDArray[np.int64], layers: list[NDArray[Any]], *, level: int, fill: Any, dtype: str
) -> Iterator[tuple[int, int, bytes]]:
    """(bx, by, blob) per block of TILES_PER_BLOCK² tiles of ``level``: one row-major (south first)
    raster of ``dtype`` per layer, ``fill`` where no tile."""
    side = TILES_PER_BLOCK * level
    bx, by = np.floor_divide(xg, side), np.floor_divide(yg, side)
    col = (xg - bx * side) // level
    row = (yg - by * side) // level
    order = np.lexsort((by, bx))
    starts = group_starts(bx[order], by[order])
    for s, e in zip(starts, np.r_[starts[1:], len(order)]):
        sel = order[s:e]
        raster = np.full((len(layers), TILES_PER_BLOCK, TILES_PER_BLOCK), fill, dtype)
        for k, layer in enumerate(layers):
            raster[k, row[sel], col[sel]] = layer[sel]
        yield int(bx[sel[0]]), int(by[sel[0]]), raster.tobytes()


def _from_raster_blocks(
    blocks: list[tuple[int, int, bytes]],
    bbox: tuple[float, float, float, float],
    *,
    level: int,
    layers: int,
    dtype: str,
    held: Callable[[NDArray[Any]], NDArray[np.bool_]],
) -> tuple[NDArray[np.int64], NDArray[np.int64], list[NDArray[Any]]]:
    """(xg, yg, layers) of the tiles of ``blocks`` overlapping ``bbox``, block by block; a tile is
    held where ``held`` says so of the last layer."""
    side = TILES_PER_BLOCK * level
    x0, y0, x1, y1 = bbox
    picked = []
    for bx, by, blob in blocks:
        raster = np.frombuffer(blob, dtype).reshape(layers, TILES_PER_BLOCK, TILES_PER_BLOCK)
        xs = bx * side + np.arange(TILES_PER_BLOCK, dtype=np.int64) * level
        ys = by * side + np.arange(TILES_PER_BLOCK, dtype=np.int64) * level
        cols = np.flatnonzero((xs + level > x0) & (xs < x1))
        rows = np.flatnonzero((ys + level > y0) & (ys < y1))
        if len(cols) == 0 or len(rows) == 0:
            continue
        # the tiles in a box are a run of rows and columns: slices, not a gather
        sub = raster[:, rows[0] : rows[-1] + 1, cols[0] : cols[-1] + 1]
        mask = held(sub[-1])
        # a part wholly held (the common case inside a survey) needs no list of its tiles
        picked.append((xs[cols[0] : cols[-1] + 1], ys[rows[0] : rows[-1] + 1], sub, None if mask.all() else mask))
    return _gathered(picked, layers, dtype)


def _gathered(
    picked: list[tuple[NDArray[np.int64], NDArray[np.int64], NDArray[Any], NDArray[np.bool_] | None]],
    layers: int,
    dtype: str,
) -> tuple[NDArray[np.int64], NDArray[np.int64], list[NDArray[Any]]]:
    """The held tiles of each block's part (its columns' x, rows' y, layers, held mask or None
    where all are held), row by row, written once into arrays of the final size."""
    total = sum(sub[0].size if mask is None else int(mask.sum()) for _, _, sub, mask in picked)
    xg, yg = np.empty(total, np.int64), np.empty(total, np.int64)
    values = np.empty((layers, total), dtype)
    start = 0
    for xs, ys, sub, mask in picked:
        if mask is None:
            h, w = sub.shape[1:]
            stop = start + h * w
            xg[start:stop].reshape(h, w)[:] = xs[None, :]
            yg[start:stop].reshape(h, w)[:] = ys[:, None]
            for k in range(layers):
                values[k, start:stop].reshape(h, w)[:] = sub[k]
        else:
            r, c = np.nonzero(mask)
            stop = start + len(r)
            xg[start:stop], yg[start:stop] = xs[c], ys[r]
            values[:, start:stop] = sub[:, r, c]
        start = stop
    return xg, yg, list(values)


def tile_blocks(
    xg: NDArray[np.int64], yg: NDArray[np.int64], code: NDArray[np.uint8], *, level: int
) -> Iterator[tuple[int, int, bytes]]:
    """(bx, by, blob) per block: a row-major (south first) raster of codes, ABSENT where no tile."""
    return _raster_blocks(xg, yg, [code], level=level, fill=ABSENT, dtype="u1")


def tiles_from_blocks(
    blocks: list[tuple[int, int, bytes]], bbox: tuple[float, float, float, float], *, level: int
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.uint8]]:
    """(xg, yg, code) of the tiles of ``blocks`` overlapping ``bbox``, block by block."""
    xg, yg, (code,) = _from_raster_blocks(
        blocks, bbox, level=level, layers=1, dtype="u1", held=lambda r: r != ABSENT
    )
    return xg, yg, code


def evidence_blocks(
    xg: NDArray[np.int64], yg: NDArray[np.int64], fields: list[NDArray[np.floating]]
) -> Iterator[tuple[int, int, bytes]]:
    """(bx, by, blob) per block of 2 m tiles: one row-major float16 raster per field of
    ``fields`` (:class:`tdb.evidence.TileEvidence`'s), NaN where no tile."""
    return _raster_blocks(xg, yg, fields, level=2, fill=np.nan, dtype="<f2")


def evidence_from_blocks(
    blocks: list[tuple[int, int, bytes]], bbox: tuple[float, float, float, float], *, fields: int
) -> tuple[NDArray[np.int64], NDArray[np.int64], list[NDArray[np.float32]]]:
    """(xg, yg, fields) of the 2 m tiles of ``blocks`` overlapping ``bbox``; a tile is held where
    its last field is not NaN. A page written before a field was added lacks it: NaN there."""
    pages = [(bx, by, _with_fields(blob, fields)) for bx, by, blob in blocks]
    xg, yg, values = _from_raster_blocks(
        pages, bbox, level=2, layers=fields, dtype="<f2", held=lambda r: ~np.isnan(r)
    )
    return xg, yg, [v.astype(np.float32) for v in values]


def _with_fields(blob: bytes, fields: int) -> bytes:
    """An evidence page of ``fields`` layers from one of fewer, older ones: the fields added since
    (all before the last, which says where a tile is held) NaN."""
    plane = TILES_PER_BLOCK * TILES_PER_BLOCK
    found = len(blob) // (2 * plane)
    if found >= fields:
        return blob
    old = np.frombuffer(blob, "<f2").reshape(found, plane)
    added = np.full((fields - found, plane), np.nan, "<f2")
    return np.concatenate([old[:-1], added, old[-1:]]).tobytes()


def merge_raster_pages(old: bytes, new: bytes, *, dtype: str, layers: int, fill: Any) -> bytes:
    """One raster page from two parts of it written apart (a page wider than the part of a
    survey that wrote each): the tiles of ``new`` where it holds them, those of ``old`` elsewhere."""
    a = np.frombuffer(old, dtype).reshape(layers, TILES_PER_BLOCK, TILES_PER_BLOCK)
    b = np.frombuffer(new, dtype).reshape(layers, TILES_PER_BLOCK, TILES_PER_BLOCK)
    held = np.isnan(b[-1]) if isinstance(fill, float) and np.isnan(fill) else b[-1] == fill
    return np.where(held[None], a, b).tobytes()


def merge_tile_pages(old: bytes, new: bytes) -> bytes:
    """A code page (:func:`tile_blocks`) from two parts written apart."""
    return merge_raster_pages(old, new, dtype="u1", layers=1, fill=ABSENT)


def merge_evidence_pages(old: bytes, new: bytes, *, fields: int) -> bytes:
    """An evidence page (:func:`evidence_blocks`) from two parts written apart."""
    return merge_raster_pages(
        _with_fields(old, fields), _with_fields(new, fields), dtype="<f2", layers=fields, fill=np.nan
    )
