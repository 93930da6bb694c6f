"""The one reader of point clouds: LAS/LAZ (laspy + lazrs), ISPRS-style text, arrays.

Every reader returns a :class:`tdb.cloud.PointCloud` in the file's own units;
:func:`tdb.units.to_metres` converts. LAS/LAZ is read in chunks into
preallocated arrays, so memory is what is kept, not what is decoded.
"""

from __future__ import annotations

import copy
import os
import warnings
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

import laspy
import numpy as np
from numpy.typing import NDArray

from tdb.atomic import atomic_path
from tdb.bbox import column_range, points_in_box
from tdb.cloud import PointCloud, check_finite, check_spread, from_arrays
from tdb.errors import FormatError, InputError, TdbIOError
from tdb.options import LabelScheme, parse
from tdb.units import as_crs


def read(
    path: str | os.PathLike[str],
    *,
    crs: Any = None,
    labels: str | LabelScheme = LabelScheme.ASPRS,
    chunk_size: int = 1_000_000,
    validate: bool = True,
) -> PointCloud:
    """Read a point cloud from a LAS/LAZ or text file.

    Parameters
    ----------
    path : a ``.las``/``.laz`` file, or a text file of ``x y z [label]`` rows.
    crs : overrides (or supplies) the file's coordinate system.
    labels : meaning of a text file's fourth column (see :class:`LabelScheme`).
    chunk_size : points decoded at a time from LAS/LAZ.
    validate : check for NaN/infinite coordinates and degenerate spread.

    Raises
    ------
    TdbIOError
        If the file is missing or unreadable.
    FormatError
        If the file is truncated, corrupt or malformed.
    InputError
        If it holds no points, non-finite coordinates, or points spanning no area.
    """
    p = Path(path)
    if not p.exists():
        raise TdbIOError(f"{p}: no such file")
    if not p.is_file():
        raise TdbIOError(f"{p}: not a file")
    if not os.access(p, os.R_OK):
        raise TdbIOError(f"{p}: permission denied")
    if is_las(p):
        cloud = _read_las(p, chunk_size=chunk_size)
    elif p.suffix.lower() in LAS_SUFFIXES:
        # a damaged download or a wrong name, not a text table: say what it is not
        raise FormatError(f"{p}: not a LAS/LAZ file (it does not begin with the signature 'LASF')")
    else:
        cloud = _read_text(p, labels=parse(LabelScheme, labels))
    if crs is not None:
        cloud = replace(cloud, crs=as_crs(crs))
    if validate:
        check_finite(cloud)
        check_spread(cloud)
    return cloud


Box = tuple[float, float, float, float]
RANGE_PAD = 1.0  # m around a box its COPC nodes are found in; the box itself is applied after

RECORD = np.dtype([("x", "<f8"), ("y", "<f8"), ("z", "<f8"), ("c", "u1"), ("r", "u1"), ("n", "u1"), ("w", "?")])
"""One LAS point as tdb models it: coordinates, class, return number, number of returns, withheld."""


def iter_records(
    path: str | os.PathLike[str], *, chunk_size: int = 1_000_000, box: Box | None = None
) -> Iterator[NDArray[Any]]:
    """A LAS/LAZ file's points as :data:`RECORD` arrays, ``chunk_size`` at a time; with ``box``
    (x0, y0, x1, y1, edges included) only the points inside it. A COPC file is then read by
    range: only the octree nodes that reach the box are decoded.

    Raises
    ------
    FormatError
        If the file is not a readable LAS/LAZ file, or its point data is corrupt.
    """
    p = Path(path)
    try:
        reader = laspy.open(p)
    except Exception as exc:  # the parser raises struct, value, lazrs... errors on bad bytes
        raise FormatError(f"{p}: not a readable LAS/LAZ file ({exc})") from None
    with reader:
        try:
            if box is not None and is_copc(reader.header):
                yield _copc_box(p, box)
                return
            for chunk in reader.chunk_iterator(chunk_size):
                rec = _record(chunk)
                yield rec if box is None else rec[in_box(rec, box)]
        except Exception as exc:  # any decoder failure means corrupt data
            raise FormatError(f"{p}: corrupt or truncated point data ({exc})") from None


def is_copc(header: laspy.LasHeader) -> bool:
    """Whether a LAS header is a COPC file's (its first VLR is the ``copc`` info record)."""
    return any(v.user_id == "copc" and v.record_id == 1 for v in header.vlrs)


def _copc_box(path: Path, box: Box) -> NDArray[Any]:
    x0, y0, x1, y1 = box
    # laspy's query leaves out points on the box's far edges, which a box here includes.
    pad = RANGE_PAD
    with laspy.CopcReader.open(path) as reader:
        points = reader.query(
            bounds=laspy.Bounds(mins=np.array([x0 - pad, y0 - pad]), maxs=np.array([x1 + pad, y1 + pad]))
        )
    rec = _record(points)
    return rec[in_box(rec, box)]


def _record(points: Any) -> NDArray[Any]:
    rec = np.empty(len(points), RECORD)
    rec["x"], rec["y"], rec["z"] = points.x, points.y, points.z
    rec["c"], rec["r"], rec["n"] = points.classification, points.return_number, points.number_of_returns
    rec["w"] = points.withheld
    return rec


def from_records(rec: NDArray[Any], *, crs: Any, source: str) -> PointCloud:
    """A :class:`PointCloud` of :data:`RECORD` points (legacy zero return numbers read as 1)."""
    rn = np.maximum(rec["r"], 1).astype(np.uint8)
    return PointCloud(
        xyz=np.column_stack([rec["x"], rec["y"], rec["z"]]),
        classification=rec["c"].astype(np.uint8),
        return_number=rn,
        number_of_returns=np.maximum(rec["n"], rn).astype(np.uint8),
        withheld=_flagged(rec["w"]),
        crs=crs,
        source=source,
    )


def _flagged(flags: NDArray[Any]) -> NDArray[np.bool_] | None:
    """The withheld flags as a mask, or None where no point is flagged (the common case)."""
    mask = np.asarray(flags, bool)
    return mask if mask.any() else None


def in_box(rec: NDArray[Any], box: Box) -> NDArray[np.bool_]:
    """Which points lie in ``box`` (x0, y0, x1, y1; edges included)."""
    return points_in_box(rec["x"], rec["y"], box)


def read_box(path: str | os.PathLike[str], box: Box, *, chunk_size: int = 1_000_000) -> PointCloud:
    """The points of a LAS/LAZ file inside ``box`` (x0, y0, x1, y1; edges included), decoded
    chunk by chunk so that only the box's points are ever held.

    Raises
    ------
    TdbIOError, FormatError
        As :func:`read`, for a missing, unreadable or corrupt file.
    """
    p = Path(path)
    if not p.is_file():
        raise TdbIOError(f"{p}: no such file")
    parts = list(iter_records(p, chunk_size=chunk_size, box=box))
    return from_records(np.concatenate(parts) if parts else np.zeros(0, RECORD), crs=las_crs(p), source=str(p))


def las_crs(path: Path) -> Any:
    """The coordinate system a LAS/LAZ file's header declares (None where none)."""
    try:
        with laspy.open(path) as reader:
            return reader.header.parse_crs()
    except Exception as exc:  # laspy raises several types for odd headers and CRS records
        raise FormatError(f"{path}: unreadable header or coordinate system record ({exc})") from None


LAS_SUFFIXES = (".las", ".laz")


def is_las(path: Path) -> bool:
    """Whether a file starts as a LAS/LAZ file does (its signature)."""
    with path.open("rb") as fh:
        return fh.read(4) == b"LASF"


def _read_las(path: Path, *, chunk_size: int) -> PointCloud:
    try:
        reader = laspy.open(path)
    except Exception as exc:  # the parser raises struct, value, lazrs... errors on bad bytes
        raise FormatError(f"{path}: not a readable LAS/LAZ file ({exc})") from None
    with reader:
        header = reader.header
        n = int(header.point_count)
        if n == 0:
            raise InputError(f"{path}: no points")
        _check_las_size(path, header, n)
        dims = set(header.point_format.dimension_names)
        xyz = np.empty((n, 3), np.float64)
        cls = np.empty(n, np.uint8)
        rn = np.empty(n, np.uint8)
        nr = np.empty(n, np.uint8)
        withheld = np.empty(n, bool)
        inten = np.empty(n, np.uint16) if "intensity" in dims else None
        at = 0
        try:
            for chunk in reader.chunk_iterator(chunk_size):
                m = len(chunk)
                if m == 0:
                    break
                stop = min(at + m, n)
                take = stop - at
                xyz[at:stop, 0] = np.asarray(chunk.x[:take])
                xyz[at:stop, 1] = np.asarray(chunk.y[:take])
                xyz[at:stop, 2] = np.asarray(chunk.z[:take])
                cls[at:stop] = np.asarray(chunk.classification[:take])
                rn[at:stop] = np.asarray(chunk.return_number[:take])
                nr[at:stop] = np.asarray(chunk.number_of_returns[:take])
                withheld[at:stop] = np.asarray(chunk.withheld[:take])
                if inten is not None:
                    inten[at:stop] = np.asarray(chunk.intensity[:take])
                at = stop
                if at >= n:
                    break
        except Exception as exc:  # as above: any decoder failure means corrupt data
            raise FormatError(f"{path}: corrupt or truncated point data ({exc})") from None
        if at < n:
            raise FormatError(f"{path}: truncated; header promises {n} points, file holds {at}")
        _check_header_bounds(path, header, xyz)
        try:
            crs = header.parse_crs()
        except Exception as exc:  # laspy raises several types for odd CRS records
            raise FormatError(f"{path}: unreadable coordinate system record ({exc})") from None
    # Legacy LAS stores return numbers of 0 for single returns in some writers.
    np.maximum(rn, 1, out=rn)
    np.maximum(nr, rn, out=nr)
    return PointCloud(
        xyz=xyz,
        classification=cls,
        return_number=rn,
        number_of_returns=nr,
        intensity=inten,
        withheld=_flagged(withheld),
        crs=crs,
        source=str(path),
        meta={"las_version": str(header.version), "point_format": int(header.point_format.id)},
    )


def _check_las_size(path: Path, header: Any, n: int) -> None:
    """Uncompressed LAS: the file must be long enough for the points it promises."""
    if path.suffix.lower() == ".laz" or header.are_points_compressed:
        return
    need = header.offset_to_point_data + n * header.point_format.size
    have = path.stat().st_size
    if have < need:
        got = max(0, (have - header.offset_to_point_data) // header.point_format.size)
        raise FormatError(f"{path}: truncated; header promises {n} points, file holds {got}")


def _check_header_bounds(path: Path, header: Any, xyz: np.ndarray) -> None:
    """Decoded points must lie in the header's box: a corrupt LAZ chunk decodes to garbage
    without any error from the decoder, and this is where it shows."""
    mins, maxs = np.asarray(header.mins, float), np.asarray(header.maxs, float)
    if not (maxs > mins).any():
        return  # some writers leave the box unset
    slack = 0.01 * (maxs - mins) + 2 * np.asarray(header.scales, float)
    lo, hi = column_range(xyz)
    if (lo < mins - slack).any() or (hi > maxs + slack).any():
        raise FormatError(f"{path}: points lie outside the header's bounding box (corrupt point data)")


def _read_text(path: Path, *, labels: LabelScheme) -> PointCloud:
    try:
        with path.open("rb") as fh:
            head = fh.read(4096)
    except OSError as exc:
        raise TdbIOError(f"{path}: {exc.strerror}") from None
    if b"\0" in head:
        raise FormatError(f"{path}: binary file that is neither LAS nor LAZ")
    delimiter = "," if b"," in head.split(b"\n", 1)[0] else None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # an empty file is reported below, as an error
            data = np.loadtxt(path, delimiter=delimiter, ndmin=2, dtype=np.float64, comments="#")
    except ValueError as exc:
        raise FormatError(f"{path}: not a table of numbers ({_first_line(exc)})") from None
    if data.size == 0:
        raise InputError(f"{path}: no points")
    cols = data.shape[1]
    if cols not in (3, 4):
        raise FormatError(f"{path}: expected 3 columns (x y z) or 4 (x y z label), found {cols}")
    classification = None
    if cols == 4:
        raw = data[:, 3]
        if labels is LabelScheme.ISPRS:
            classification = np.where(raw == 0, 2, 1).astype(np.uint8)
        else:
            if (raw < 0).any() or (raw > 255).any() or (raw != np.round(raw)).any():
                raise FormatError(f"{path}: label column must hold class codes 0..255")
            classification = raw.astype(np.uint8)
    return from_arrays(
        data[:, 0], data[:, 1], data[:, 2], classification=classification, source=str(path), validate=False
    )


def _first_line(exc: Exception) -> str:
    return str(exc).splitlines()[0] if str(exc) else type(exc).__name__


def write_classified(path: str | os.PathLike[str], cloud: PointCloud, classification: NDArray[Any]) -> None:
    """Write ``cloud`` with new classes, in its input order.

    Where ``cloud`` was read from a LAS/LAZ file, that file's points are copied record by
    record, chunk by chunk, with only their class changed: times, colours, scan angles, flags,
    extra bytes, the point format and the header's records stay as the producer wrote them
    (every ASPRS class tdb writes fits the 5 bits of the oldest formats). A CRS given for a
    file that names none, or in place of its own, is written into the header. Other clouds are
    written as :func:`write_las` writes them. The file is moved into place once whole.

    Raises
    ------
    TdbIOError
        If the source file no longer holds the cloud's points.
    """
    source = Path(cloud.source)
    codes = np.asarray(classification, np.uint8)
    if "point_format" not in cloud.meta or not source.is_file():
        write_las(path, cloud, classification=codes)
        return
    p = Path(path)
    with laspy.open(source) as reader:
        header = _output_header(reader.header, cloud.crs)
        if reader.header.point_count != len(codes):
            raise TdbIOError(f"{source}: the file changed while it was classified")
        with (
            atomic_path(p) as tmp,
            laspy.open(tmp, mode="w", header=header, do_compress=p.suffix.lower() == ".laz") as writer,
        ):
            at = 0
            for chunk in reader.chunk_iterator(1_000_000):
                chunk.classification = codes[at : at + len(chunk)]
                writer.write_points(chunk)
                at += len(chunk)


def _output_header(source: laspy.LasHeader, crs: Any) -> laspy.LasHeader:
    """The source's header for a copy of its points, with ``crs``."""
    header = copy.deepcopy(source)
    # the octree's index records say where a COPC file's pages lie; the copy is a plain file
    header.vlrs[:] = [v for v in header.vlrs if v.user_id != "copc"]
    if crs is not None and source.parse_crs() != crs:
        header.add_crs(crs)
    return header


def write_las(
    path: str | os.PathLike[str],
    cloud: PointCloud,
    *,
    classification: np.ndarray | None = None,
    scale: float = 0.001,
) -> None:
    """Write ``cloud`` as LAS 1.4 (point format 6), LAZ where ``path`` ends in ``.laz``.

    The file is written next to its destination and moved into place, so a
    failure leaves no half-written file.
    """
    p = Path(path)
    header = laspy.LasHeader(point_format=6, version="1.4")
    lo = column_range(cloud.xyz)[0]
    header.offsets = np.floor(lo)
    header.scales = np.array([scale, scale, scale])
    if cloud.crs is not None:
        header.add_crs(cloud.crs)
    las = laspy.LasData(header)
    las.x, las.y, las.z = cloud.x, cloud.y, cloud.z
    las.classification = cloud.classification if classification is None else classification
    las.return_number = cloud.return_number
    las.number_of_returns = cloud.number_of_returns
    if cloud.intensity is not None:
        las.intensity = cloud.intensity
    if cloud.withheld is not None:
        las.withheld = cloud.withheld
    with atomic_path(p) as tmp:
        las.write(str(tmp), do_compress=p.suffix.lower() == ".laz")
