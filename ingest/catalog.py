"""A catalog of LAS/LAZ tiles: one survey in many files, indexed by their headers.

Like lidR's LAScatalog, a catalog reads only the headers up front (bounds, point counts, CRS),
then the points of any box from the files that reach it, chunk by chunk. Tiles may overlap
(their points in a box are merged, each once: :mod:`ingest.overlaps`); tiles in different
coordinate systems are refused.
"""

from __future__ import annotations

import glob
import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import laspy
import numpy as np
from numpy.typing import NDArray

from ingest.block_size import block_bytes
from ingest.overlaps import SharedPoints
from ingest.readers import RECORD, Box, from_records, in_box, is_las, iter_records
from tdb.bbox import box_area, overlaps
from tdb.cloud import PointCloud
from tdb.crs import describe
from tdb.errors import CRSError, FormatError, InputError, TdbError, TdbIOError
from tdb.memory import physical_bytes
from tdb.units import units_of, with_metre_axes

SUFFIXES = (".las", ".laz")
CHUNK = 1_000_000  # points decoded at a time


@dataclass(frozen=True)
class CatalogFile:
    """One tile of a catalog: its path, header bounds (x0, y0, x1, y1) and point count."""

    path: Path
    bounds: Box
    points: int


@dataclass(frozen=True)
class Catalog:
    """The tiles of one survey and their shared coordinate system.

    ``scale`` is the metres per unit (horizontal, vertical) its points are read in: (1, 1) as the
    files hold them; a catalog :meth:`in_metres` of files in feet reads them in metres."""

    files: tuple[CatalogFile, ...]
    crs: Any
    scale: tuple[float, float] = (1.0, 1.0)

    def in_metres(self) -> Catalog:
        """The same tiles, read in metres where their coordinate system is projected in other
        units (feet): bounds and points scaled exactly, the CRS the same with metre axes, as
        :func:`tdb.units.to_metres` converts a cloud. A catalog in metres, with no CRS, or in
        degrees (which need a projection, not a scale) is returned as it is."""
        units = units_of(self.crs)
        if units is None or units.metric or units.geographic:
            return self
        h, v = units.horizontal_factor, units.vertical_factor
        x0, y0, x1, y1 = (np.array([f.bounds for f in self.files]) * h).T.tolist()
        files = tuple(replace(f, bounds=b) for f, b in zip(self.files, zip(x0, y0, x1, y1)))
        return Catalog(files, with_metre_axes(self.crs), (h, v))

    def records(self, f: CatalogFile, *, chunk_size: int, box: Box | None = None) -> Iterator[NDArray[Any]]:
        """The points of one of the catalog's files (in ``box``, edges included) as
        :data:`ingest.readers.RECORD` arrays in the catalog's units, ``chunk_size`` at a time."""
        h, v = self.scale
        if (h, v) == (1.0, 1.0):
            yield from iter_records(f.path, chunk_size=chunk_size, box=box)
            return
        # the box in the file's units, a unit wider, so that rounding loses no point on its edge
        wide = None if box is None else (box[0] / h - 1, box[1] / h - 1, box[2] / h + 1, box[3] / h + 1)
        for rec in iter_records(f.path, chunk_size=chunk_size, box=wide):
            rec["x"] *= h
            rec["y"] *= h
            rec["z"] *= v
            yield rec if box is None else rec[in_box(rec, box)]

    @property
    def bounds(self) -> Box:
        """The union of the tiles' header bounds."""
        b = np.array([f.bounds for f in self.files])
        return (float(b[:, 0].min()), float(b[:, 1].min()), float(b[:, 2].max()), float(b[:, 3].max()))

    @property
    def points(self) -> int:
        return sum(f.points for f in self.files)

    @property
    def densest(self) -> float:
        """Points per m² of the densest tile by its header (a survey's bounds hold gaps between tiles)."""
        out = 0.0
        for f in self.files:
            x0, y0, x1, y1 = f.bounds
            if x1 > x0 and y1 > y0:
                out = max(out, f.points / ((x1 - x0) * (y1 - y0)))
        return out

    def read(self, box: Box) -> PointCloud:
        """The points of every tile inside ``box`` (edges included), merged, each once where
        tiles overlap (:mod:`ingest.overlaps`)."""
        shared = SharedPoints([f.bounds for f in self.files])
        parts = [
            shared(i, rec)
            for i, f in enumerate(self.files)
            if overlaps(f.bounds, box)
            for rec in self.records(f, chunk_size=CHUNK, box=box)
        ]
        rec = np.concatenate(parts) if parts else np.zeros(0, RECORD)
        return from_records(rec, crs=self.crs, source=f"catalog of {len(self.files)} files")


def open_catalog(source: str | os.PathLike[str] | Sequence[str | os.PathLike[str]]) -> Catalog:
    """A catalog of a directory's LAS/LAZ files, a glob pattern's, or a list of files.

    Raises
    ------
    InputError
        If no LAS/LAZ file is found.
    CRSError
        If the tiles are in different coordinate systems.
    TdbIOError, FormatError
        If a file is missing or its header unreadable.
    """
    paths = _paths(source)
    if not paths:
        raise InputError(f"{source}: no LAS/LAZ files")
    files, systems = [], []
    for path in paths:
        if path.is_file() and not is_las(path):
            raise FormatError(
                f"{path}: not a LAS/LAZ file; tiles, and surveys modelled block by block, are read from "
                "LAS/LAZ files only (a text file is modelled whole: convert a larger one to LAZ)"
            )
        try:
            with laspy.open(path) as reader:
                h = reader.header
                crs = h.parse_crs()
                files.append(
                    CatalogFile(
                        path,
                        (float(h.mins[0]), float(h.mins[1]), float(h.maxs[0]), float(h.maxs[1])),
                        int(h.point_count),
                    )
                )
        except OSError as exc:
            raise TdbIOError(f"{path}: {exc.strerror or exc}") from None
        except Exception as exc:  # laspy raises several types on a bad header
            raise FormatError(f"{path}: not a readable LAS/LAZ file ({exc})") from None
        systems.append(crs)
    first = systems[0]
    for path, crs in zip(paths[1:], systems[1:]):
        same = (crs is None and first is None) or (
            crs is not None and first is not None and crs.equals(first, ignore_axis_order=True)
        )
        if not same:
            raise CRSError(
                f"{path}: in {describe(crs)}, while {paths[0]} is in {describe(first)}; "
                "a catalog's tiles must share one coordinate system"
            )
    return Catalog(tuple(files), first)


WHOLE_BYTES_PER_POINT = 2_000  # a whole ingest's peak memory per point read (sparse surveys, the most)
METRES_PER_DEGREE = 111_320.0  # along the equator or a meridian: enough for an estimate of memory


def too_large_to_model_whole(path: str | os.PathLike[str], *, memory: int | None = None) -> bool:
    """Whether a LAS/LAZ file is too large for a whole ingest in half of ``memory`` bytes
    (default: this machine's): by its points, at :data:`WHOLE_BYTES_PER_POINT` each, or by the
    extent of its header's bounds, whose grids a whole ingest lays out filled or not
    (:func:`ingest.block_size.block_bytes`). Such a file goes block by block, where only the
    blocks that hold points are modelled. False for a file whose header gives no count (a text file)."""
    p = Path(path)
    if p.suffix.lower() not in SUFFIXES or not p.is_file():
        return False
    try:
        catalog = open_catalog([p])
    except TdbError:
        return False  # the reader says what is wrong, as for any file
    if memory is None:
        memory = physical_bytes()
    points = catalog.points
    need = max(points * WHOLE_BYTES_PER_POINT, block_bytes(extent_m2(catalog), points))
    return bool(memory) and need > memory // 2


def extent_m2(catalog: Catalog) -> float:
    """The area (m²) of a catalog's header bounds: converted from feet (:meth:`Catalog.in_metres`),
    from degrees roughly (at the bounds' middle latitude); as metres where it names no CRS."""
    metric = catalog.in_metres()
    x0, y0, x1, y1 = metric.bounds
    area = box_area((x0, y0, x1, y1))
    units = units_of(metric.crs)
    if units is not None and units.geographic:
        return area * METRES_PER_DEGREE**2 * abs(np.cos(np.radians((y0 + y1) / 2)))
    return area


def is_catalog(source: Any) -> bool:
    """Whether ``source`` names several files: a directory, a glob pattern or a list."""
    if isinstance(source, (list, tuple)):
        return True
    text = str(source)
    return Path(text).is_dir() or any(c in text for c in "*?[")


def _paths(source: str | os.PathLike[str] | Sequence[str | os.PathLike[str]]) -> list[Path]:
    if not isinstance(source, (str, os.PathLike)):
        return [Path(p) for p in source]
    p = Path(source)
    if p.is_dir():
        return sorted(q for q in p.iterdir() if q.suffix.lower() in SUFFIXES)
    if any(c in str(source) for c in "*?["):
        return sorted(Path(q) for q in glob.glob(str(source)) if Path(q).suffix.lower() in SUFFIXES)
    return [p]
