"""Ingest of any size: the survey streamed into blocks of the output grid, each modelled with a
buffer of its neighbours' points, in parallel, and stored as one version.

1. **Scatter.** One pass over the input (a file or a catalog of tiles), chunk by chunk: each
   point goes to a temporary file per block whose buffered box holds it. Memory stays bounded
   by the chunk; disk holds the points about (1 + 2·buffer/block)² times.
2. **Model.** Each block's points are modelled as one survey (:func:`ingest.pipeline.survey`):
   ground, dense model, categories, reduction. Blocks are independent and run in as many
   processes as there are cores.
3. **Crop and merge.** A block keeps the tiles whose lower-left corner lies in its own square
   (block edges are multiples of the 16 m lattice, so the tiles of every level nest), and the
   kept points on or inside its square; points on a shared edge are kept once, with the level
   bits of both sides.
4. **Store** everything as one version, in one transaction.

**Why the buffer is 64 m.** A point's ground label depends on the points within the ground
filter's openings (windows up to 16 m radius, 68 m reach in all) and on the surface the
refinement passes rebuild from their neighbours, which bridges holes of up to 64 m and takes the
nearest ground across wider ones (``AutoParams.max_bridge``); the dense model bridges holes
(roofs, water) by a triangulation across them; the 16 m level samples a model smoothed over 2 m.
64 m holds these for holes up to 64 m across. The rest of the model (dense model, categories,
reduction, evidence, objects) reads less around a tile: the coarsest level's smoothing, the
evidence's window and a crown reach some 10–15 m. It is made from the points within
:data:`MARGIN` of the block's square only, once the filter has labelled them all, which holds
those with room; only the dense model's triangles across a hole wider than that can differ, as
the filter's do beyond 64 m. Each block's filter grid covers its read box within
the survey's bounds, so that it ends where the whole survey's does, not where its own points
do. What can still differ: object groups larger than the buffer (an embankment several hundred
metres long is judged by its whole extent). The flat threshold is one for the whole survey,
measured as a one-piece ingest measures it, on the fullest square of a fixed lattice
(:mod:`ingest.noise`), unless one is given. How often tiles
differ from a one-piece ingest of the same area is measured by ``tests/test_blocked.py`` and
``benchmarks/blocked_ingest.py``.
"""

from __future__ import annotations

import dataclasses
import itertools
import os
import tempfile
import warnings
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import as_completed
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ingest.block_lattice import BUFFER, Block, BlockLattice
from ingest.block_size import block_side
from ingest.block_totals import BlockResult, Totals
from ingest.catalog import Box, Catalog, CatalogFile, is_catalog, open_catalog
from ingest.ground import classify_ground
from ingest.ground.outliers import DENSITY_BLOCK
from ingest.noise import fullest_square, pilot_threshold, square_counts
from ingest.objects.cover import SINGLE_RETURNS
from ingest.overlaps import SharedPoints
from ingest.pipeline import IngestOptions, survey
from ingest.pyramid import LevelTiles, TerrainModel, reduction_stats
from ingest.readers import RECORD, from_records, in_box
from ingest.spool import Spool
from tdb.bbox import check_bbox, clip_bbox, overlaps, points_in_box
from tdb.categories import NO_DATA
from tdb.classes import excluded
from tdb.crs import as_crs
from tdb.database import Database, Version, VersionInfo, check_version_name
from tdb.errors import CRSError, FormatError, InputError, Remedy, TdbIOError, TdbWarning, VersionExistsError
from tdb.memory import peak_mib
from tdb.progress import Progress, or_silent
from tdb.raster import Raster
from tdb.threads import keep_freed_memory, one_blas_thread
from tdb.tiles import LEVELS, SUBGRID, tile_key
from tdb.units import to_metres, units_of
from tdb.version_writer import VersionWriter
from tdb.workers import available_cores, local_pool, one_blas_thread_here

MARGIN = 32.0  # m of the buffer the model beyond the ground filter is made from: see the module's description
CHUNK = 2_000_000  # points decoded at a time


@dataclass(frozen=True)
class Blocking:
    """How a survey is cut: blocks of ``block`` m (None: as large as a worker models within its
    memory at the survey's density, :mod:`ingest.block_size`) with ``buffer`` m of their neighbours' points,
    in ``workers`` processes (None: one per core), or on the workers of the dask.distributed
    ``scheduler`` at that address (``tcp://host:8786``): each block's points travel to a worker
    with its job, so the workers need tdb installed but no shared disk."""

    block: float | None = None
    buffer: float = BUFFER
    workers: int | None = None
    scheduler: str | None = None
    region: Box | None = None  # only this area (x0, y0, x1, y1), widened to the 16 m tiles it touches

    def __post_init__(self) -> None:
        coarsest = max(LEVELS)
        if self.region is not None:
            check_bbox(self.region)
        if self.block is not None and (self.block <= 0 or self.block % coarsest):
            raise InputError(f"a block's side must be a positive multiple of {coarsest} m, got {self.block}")
        if self.buffer < 0:
            raise InputError(f"a block's buffer cannot be negative, got {self.buffer}")


def ingest_blocked(  # noqa: PLR0913 (the source, the database, the version and how)
    source: str | os.PathLike[str] | Sequence[str | os.PathLike[str]],
    db: Database,
    *,
    version: str,
    acquired: Any = None,
    replace: bool = False,
    resume: bool = False,
    options: IngestOptions | None = None,
    blocking: Blocking | None = None,
    progress: Progress | None = None,
) -> Version:
    """Ingest a LAS/LAZ file of any size, or a catalog of tiles (a directory, a glob pattern or a
    list of files), block by block, as one version of ``db``.

    Finished blocks are kept on disk (:mod:`ingest.spool`) until the version is stored; with
    ``resume``, a run that was killed or failed continues from them.

    Raises
    ------
    VersionExistsError
        If ``version`` exists and ``replace`` is false (checked before any work).
    CRSError
        If the survey is not in projected coordinates in metres.
    ResumeError
        If ``resume`` is set and no unfinished run of the same files and settings is found.
    """
    o, b = options or IngestOptions(), blocking or Blocking()
    check_version_name(version)
    if not replace and any(v.name == version for v in db.versions()):
        raise VersionExistsError(f"{db.name}: version {version!r} exists", remedy=Remedy.REPLACE)
    report = or_silent(progress)
    catalog = open_catalog(source if is_catalog(source) else [Path(str(source))])
    if o.crs is not None:
        catalog = dataclasses.replace(catalog, crs=as_crs(o.crs))
    catalog = catalog.in_metres()
    crs = catalog.crs
    _check_metric(crs)
    if b.block is None:
        b = dataclasses.replace(b, block=block_side(catalog.densest, buffer=b.buffer))
    area = _area(catalog.bounds, b.region)
    blocks = _blocks(area, b, survey=catalog.bounds)
    spool = Spool.beside(db, version)
    run = _run(catalog, o, b)
    settings = spool.resume(run) if resume else {}
    if not resume:
        spool.start(run)
    done = set(spool.finished())
    # Where only a region is wanted, only it and its buffer are read (COPC files by range).
    wanted = None if b.region is None else _grown(area, b.buffer)
    info = VersionInfo(acquired=acquired, source=_described(catalog), crs=None if crs is None else crs.to_wkt())
    # The workers start now, so that they load their modules while this process reads the input.
    with _pool(b, len(blocks) - len(done)) as pool, tempfile.TemporaryDirectory(prefix="tdb-blocks-") as tmp:
        sc = _scatter(catalog, blocks, Path(tmp), report, exclude=o.exclude, box=wanted, skip=done)
        o = _resolved(o, settings, sc, blocks, b, crs, report)
        spool.record({"density": o.density, "flat_threshold": o.flat_threshold})
        # Blocks are written as they come, while the others are modelled, into the one
        # transaction of the version: nothing is committed before the last block.
        with db.writing(version, info=info, replace=replace) as writer:
            store = _Store(writer, o, twice=sc.twice)
            for k in sorted(done):
                store.add(spool.get(k))
            jobs = _jobs(blocks, sc.files, o, crs, skip=done)
            _model(jobs, b, pool, Counted(report, sc.own), keep=_Kept(spool, store))
            store.describe(area)
    if not store.totals.echo_test:
        warnings.warn(f"{catalog.files[0].path}: {SINGLE_RETURNS}", TdbWarning, stacklevel=2)
    spool.remove()
    return db.version(version)


def _run(catalog: Catalog, o: IngestOptions, b: Blocking) -> dict[str, Any]:
    """What makes two runs the same run, for :meth:`Spool.resume`."""
    source = []
    for f in catalog.files:
        st = f.path.stat()
        source.append([str(f.path.resolve()), st.st_size, st.st_mtime_ns])
    return {
        "source": source,
        "blocks": [b.block, b.buffer, b.region],
        "options": {k: str(v) for k, v in dataclasses.asdict(o).items()},
    }


def _resolved(
    o: IngestOptions,
    settings: dict[str, Any],
    sc: Scattered,
    blocks: BlockLattice,
    b: Blocking,
    crs: Any,
    report: Progress,
) -> IngestOptions:
    """The options with the survey's point density and flat threshold filled in: as the
    unfinished run measured them where resumed, else measured now."""
    if o.density is None:
        found = settings.get("density") or sc.density
        if found:
            o = dataclasses.replace(o, density=found)
    if o.flat_threshold is None:
        found = settings.get("flat_threshold") or _pilot_threshold(sc, blocks, b.buffer, o, crs, report)
        o = dataclasses.replace(o, flat_threshold=found)
    return o


def _area(bounds: Box, region: Box | None) -> Box:
    """The survey's extent, or the part of it in ``region``, widened to whole 16 m tiles."""
    if region is None:
        return bounds
    x0, y0, x1, y1 = clip_bbox(region, bounds, what="the survey")
    t = max(LEVELS)
    return (
        float(np.floor(x0 / t) * t),
        float(np.floor(y0 / t) * t),
        float(np.ceil(x1 / t) * t),
        float(np.ceil(y1 / t) * t),
    )


def _check_metric(crs: Any) -> None:
    units = units_of(crs)
    if units is None:
        raise CRSError("the survey names no coordinate system; give one", remedy=Remedy.GIVE_CRS)
    if not units.metric:
        raise CRSError(
            f"a survey is ingested block by block only in projected coordinates in metres, not in "
            f"{crs.name}; reproject it (or ingest it whole)"
        )


def _blocks(bounds: Box, b: Blocking, *, survey: Box | None = None) -> BlockLattice:
    """The blocks over ``bounds``; with a region, cut to it (``bounds`` is then on the 16 m tiles).
    ``survey``: the whole survey's bounds (default ``bounds``)."""
    assert b.block is not None, "ingest_blocked sets the side from the survey's density"
    return BlockLattice(bounds, b.block, b.buffer, survey or bounds, cut=b.region is not None)


def _grown(box: Box, by: float) -> Box:
    return (box[0] - by, box[1] - by, box[2] + by, box[3] + by)


@dataclass(frozen=True)
class Scattered:
    """What the pass over the input leaves: a file of points per block, the survey's point
    density, how many points each block owns, the points per pilot square (:mod:`ingest.noise`),
    and how many points overlapping tiles held twice."""

    files: dict[int, Path]  # the blocks that hold points
    density: float
    own: dict[int, int]
    squares: dict[tuple[int, int], int]
    twice: int = 0  # points dropped as held by two overlapping tiles (ingest.overlaps)


def _scatter(
    catalog: Catalog,
    blocks: BlockLattice,
    tmp: Path,
    report: Progress,
    *,
    exclude: tuple[int, ...],
    box: Box | None = None,
    skip: set[int] | frozenset[int] = frozenset(),
) -> Scattered:
    """One pass over the input (or its points in ``box``): every point, once where tiles overlap,
    appended to the file of each block whose buffered box holds it; the survey's point density as the ground filter
    measures it on the points it sees (those not of the ``exclude`` classes), over the whole survey,
    once; how many points each block owns (in its square, for the progress of the modelling); and
    how many points it sees in each pilot square. The blocks of ``skip`` (finished by an earlier
    run) get no file."""
    files: dict[int, Path] = {}
    own: Counter[int] = Counter()
    modelled = blocks.cores()
    finished = np.fromiter(skip, np.int64)
    done, total = 0, catalog.points
    seen, cells = 0, []
    squares: Counter[tuple[int, int]] = Counter()
    report("reading", 0, total)
    shared = SharedPoints([f.bounds for f in catalog.files])
    for i, f in enumerate(catalog.files):
        if box is not None and not overlaps(f.bounds, box):
            continue
        for chunk in catalog.records(f, chunk_size=CHUNK, box=box):
            done += len(chunk)
            rec = shared(i, chunk)
            if box is None:
                _check_in_header_bounds(rec, f, modelled)
            use = ~excluded(rec["c"], exclude) & ~rec["w"]
            seen += int(use.sum())
            cells.append(np.unique(tile_key(*(np.floor(rec[a][use] / DENSITY_BLOCK) for a in "xy"))))
            squares.update(square_counts(rec["x"][use], rec["y"][use]))
            for block, at, owned in blocks.groups(rec["x"], rec["y"], skip=finished):
                own[block] += int(owned.sum())
                path = files.setdefault(block, tmp / f"block{block}.bin")
                with path.open("ab") as fh:
                    rec[at].tofile(fh)
            report("reading", done, total)
    occupied = len(np.unique(np.concatenate(cells))) * DENSITY_BLOCK**2 if cells else 0.0
    return Scattered(files, seen / occupied if occupied else 0.0, dict(own), dict(squares), shared.dropped)


def _check_in_header_bounds(rec: NDArray[Any], f: CatalogFile, modelled: Box) -> None:
    """Raise where points of ``f`` lie beyond the blocks, which are laid over the bounds the
    files' headers declare: a point there would belong to no block and be lost."""
    beyond = ~in_box(rec, modelled)
    if beyond.any():
        x, y = rec["x"][beyond], rec["y"][beyond]
        raise FormatError(
            f"{f.path}: {int(beyond.sum()):,} points lie beyond the bounds its header declares "
            f"(x {f.bounds[0]:.2f} .. {f.bounds[2]:.2f}, y {f.bounds[1]:.2f} .. {f.bounds[3]:.2f}; "
            f"one at {x[0]:.2f}, {y[0]:.2f}); rewrite the file so that its header holds its points' bounds"
        )


def _jobs(
    blocks: BlockLattice, files: dict[int, Path], o: IngestOptions, crs: Any, *, skip: set[int]
) -> list[Job]:
    """The blocks that hold points and are not in ``skip``, the largest first, so that no worker is
    left with a big one while the others idle."""
    jobs = [(k, blocks.block(k), path, o, crs) for k, path in sorted(files.items()) if k not in skip]
    return sorted(jobs, key=lambda j: -j[2].stat().st_size)


@contextmanager
def _pool(b: Blocking, blocks: int) -> Iterator[Any]:
    """The workers for ``blocks`` blocks, started at once: a process pool here, or a client of
    ``b``'s dask cluster (None where this process models them)."""
    if b.scheduler is not None:
        with _cluster(b.scheduler) as client:
            yield client
        return
    workers = min(b.workers or available_cores(), blocks)
    if workers <= 1:
        yield None
        return
    with local_pool(workers, preload=__name__, initializer=_worker_start) as pool:
        yield pool


def _worker_start() -> None:
    """A local worker's initializer. Being of this module, it loads every module a block needs
    when the process starts, before its first block arrives."""
    one_blas_thread_here()


@contextmanager
def _cluster(address: str) -> Iterator[Any]:
    """A client of the dask.distributed scheduler at ``address``, each of whose workers is sent a
    task of this module at once, so that it loads the modules a block needs meanwhile."""
    try:
        from distributed import Client
    except ImportError:
        raise InputError("a cluster needs dask.distributed (pip install 'tdb[cluster]')") from None
    try:
        client = Client(address, timeout=CONNECT_SECONDS)
    except OSError as exc:
        raise TdbIOError(f"{address}: no dask scheduler answers ({exc})") from None
    with client:
        # held until the run ends: a future let go may be cancelled before it runs
        loading = [
            client.submit(_loaded, pure=False, workers=[w]) for w in client.scheduler_info().get("workers", {})
        ]
        yield client
        del loading


def _loaded() -> bool:
    """Nothing: a task whose function, being of this module, makes a worker load it."""
    return True


def _model(
    jobs: list[Job],
    b: Blocking,
    pool: Any,
    report: Counted,
    *,
    keep: Callable[[int, BlockResult | None], None],
) -> None:
    """Model the blocks of ``jobs`` on ``pool`` (:func:`_pool`: ``b``'s cluster, a process pool)
    or here, each result given to ``keep`` as it comes."""
    report.start([j[0] for j in jobs])
    results: Iterator[tuple[int, BlockResult | None]]
    if b.scheduler is not None:
        results = _on_cluster(jobs, pool)
    elif pool is not None:
        results = (f.result() for f in as_completed([pool.submit(_one_block_args, job) for job in jobs]))
    else:
        results = map(_one_block_here, jobs)
    for k, r in results:
        keep(k, r)
        report.finished(k)


class Counted:
    """The modelling's progress in the survey's points (those the blocks own), so that a bar
    shows points per second and the time left: ``("modelling points", done, total)``."""

    STEP = "modelling points"

    def __init__(self, progress: Progress, own: dict[int, int]) -> None:
        self.progress, self.own, self.done, self.total = progress, own, 0, 0

    def start(self, blocks: list[int]) -> None:
        self.total = sum(self.own.get(k, 0) for k in blocks)
        self.progress(self.STEP, 0, self.total)

    def finished(self, k: int) -> None:
        self.done += self.own.get(k, 0)
        self.progress(self.STEP, self.done, self.total)


IN_FLIGHT = 2  # blocks sent per worker ahead of the results: the parent holds only these
CONNECT_SECONDS = 20  # how long a scheduler may take to answer


Job = tuple[int, Block, Path, IngestOptions, Any]  # a block's index, itself, its points' file, how, the CRS


def _on_cluster(jobs: list[Job], client: Any) -> Iterator[tuple[int, BlockResult | None]]:
    """The blocks modelled on a dask.distributed cluster (``client``), a few per worker at a time."""
    from distributed import as_completed

    ahead = IN_FLIGHT * max(1, len(client.scheduler_info().get("workers", {})))
    pending = iter(jobs)

    def send(job: Job) -> Any:
        k, blk, path, o, crs = job
        return client.submit(_one_block_at, k, blk, np.fromfile(path, RECORD), o, crs, str(path), pure=False)

    queue = as_completed([send(job) for job in itertools.islice(pending, ahead)])
    for future in queue:
        yield future.result()
        nxt = next(pending, None)
        if nxt is not None:
            queue.add(send(nxt))


def _pilot_threshold(
    sc: Scattered, blocks: BlockLattice, buffer: float, o: IngestOptions, crs: Any, report: Progress
) -> float:
    """The survey's flat threshold, measured as a one-piece ingest measures it: on the ground of
    the fullest pilot square (:mod:`ingest.noise`), filtered with a buffer's width of points
    around it, gathered from the blocks that own them."""
    report("ground noise", 0, 1)
    square = fullest_square(sc.squares)
    around = _grown(square, buffer)
    parts = []
    for k, path in sorted(sc.files.items()):
        blk = blocks.block(k)
        if overlaps(blk.core, around):
            rec = np.fromfile(path, RECORD)
            x, y = rec["x"], rec["y"]
            parts.append(
                rec[points_in_box(x, y, blk.core, closed=False) & points_in_box(x, y, around, closed=False)]
            )
    rec = np.concatenate(parts)
    cloud = from_records(rec[np.lexsort((rec["z"], rec["y"], rec["x"]))], crs=crs, source="pilot square")
    # the blocks' extents together span the survey's bounds, where a one-piece grid ends
    extent = clip_bbox(around, blocks.extents(), what="the survey")
    ground = classify_ground(
        to_metres(cloud), method=o.method, exclude=o.exclude, density=o.density, extent=extent
    )
    report("ground noise", 1, 1)
    return pilot_threshold(cloud.xyz[ground], square)


def _one_block_here(job: Job) -> tuple[int, BlockResult | None]:
    k, blk, path, o, crs = job
    return k, _one_block(blk, np.fromfile(path, RECORD), o, crs, str(path))


def _one_block_args(job: Job) -> tuple[int, BlockResult | None]:
    k, blk, path, o, crs = job
    return _one_block_at(k, blk, np.fromfile(path, RECORD), o, crs, str(path))


def _one_block_at(
    k: int, blk: Block, rec: NDArray[Any], o: IngestOptions, crs: Any, source: str
) -> tuple[int, BlockResult | None]:
    """A block modelled in a worker process (a local pool's or a cluster's), whose allocator is
    first let keep freed memory; its result carries the worker's peak memory so far."""
    keep_freed_memory()
    r = _one_block(blk, rec, o, crs, source)
    return k, None if r is None else dataclasses.replace(r, peak_mib=round(peak_mib(), 1))


def _one_block(blk: Block, rec: NDArray[Any], o: IngestOptions, crs: Any, source: str) -> BlockResult | None:
    """Model one block from its points (``RECORD`` rows) and keep what lies in its own square."""
    x0, y0, x1, y1 = blk.core
    own = points_in_box(rec["x"], rec["y"], blk.core, closed=False)
    if not own.any() or len(rec) < 3:
        return None
    cloud = from_records(rec, crs=crs, source=source)
    # A worker's warnings would not reach the caller: what they say is returned and said once.
    with one_blas_thread(), warnings.catch_warnings():
        warnings.simplefilter("ignore", TdbWarning)
        s = survey(
            cloud,
            options=dataclasses.replace(o, extent=blk.extent, model_box=_grown(blk.core, MARGIN)),
            measure=False,
        )
    m = s.model
    levels = {}
    for level, t in m.levels.items():
        keep = (t.xg >= x0) & (t.xg < x1) & (t.yg >= y0) & (t.yg < y1)
        levels[level] = LevelTiles(level, t.xg[keep], t.yg[keep], t.code[keep])
    # each kept point is one block's: the one whose half-open square holds it (closed on the
    # survey's east and north edges); its level bits are those of the tiles on both sides, as
    # the block's model reaches over its edges by the buffer
    east, north = blk.closed
    on = (m.x >= x0) & ((m.x <= x1) if east else (m.x < x1)) & (m.y >= y0) & ((m.y <= y1) if north else (m.y < y1))
    cropped = TerrainModel(levels, m.x[on], m.y[on], m.z[on], m.n[on])
    # the error of the whole block's mesh at the block's own posts: a mesh of the cropped points
    # alone would leave the posts beyond its hull out
    core_dtm = _crop(s.dtm, blk.core)
    whole = reduction_stats(core_dtm, m, n=SUBGRID)
    reduction = dataclasses.replace(
        whole,
        dense_posts=int(np.isfinite(core_dtm.data).sum()),
        kept_points=len(cropped.x),
        tiles={lv: len(t.code) for lv, t in levels.items()},
        no_data={lv: int((t.code == NO_DATA).sum()) for lv, t in levels.items()},
    )
    trees, buildings = ([], []) if s.objects is None else blk.kept(s.objects.trees, s.objects.buildings)
    return BlockResult(
        levels={lv: (t.xg, t.yg, t.code) for lv, t in levels.items()},
        points=(m.x[on], m.y[on], m.z[on], m.n[on]),
        reduction=reduction,
        points_read=int(own.sum()),
        ground=int((s.ground & points_in_box(s.cloud.xyz[:, 0], s.cloud.xyz[:, 1], blk.core, closed=False)).sum()),
        excluded=int((cloud.excluded(o.exclude) & own).sum()),
        noise=s.noise,
        flat_threshold=s.flat_threshold,
        evidence=s.evidence.take(
            (s.evidence.xg >= x0) & (s.evidence.xg < x1) & (s.evidence.yg >= y0) & (s.evidence.yg < y1)
        ),
        trees=trees,
        buildings=buildings,
        echo_test=s.objects.cover.echo_test if s.objects else True,
    )


def _crop(dtm: Raster, box: Box) -> Raster:
    """The posts of ``dtm`` whose centres lie in ``box`` (half-open)."""
    xs, ys = dtm.centres()
    cols = np.flatnonzero((xs >= box[0]) & (xs < box[2]))
    rows = np.flatnonzero((ys >= box[1]) & (ys < box[3]))
    if len(cols) == 0 or len(rows) == 0:
        return Raster(np.full((1, 1), np.nan), box[0], box[3], dtm.cell, dtm.crs)
    data = dtm.data[rows[0] : rows[-1] + 1, cols[0] : cols[-1] + 1]
    return Raster(data, dtm.x0 + cols[0] * dtm.cell, dtm.y1 - rows[0] * dtm.cell, dtm.cell, dtm.crs)


def _described(source: Catalog) -> str:
    first = source.files[0].path
    return f"{len(source.files)} file(s): {first}" + (" …" if len(source.files) > 1 else "")


@dataclass
class _Store:
    """The version being written: each block's result added as it comes, its figures summed."""

    writer: VersionWriter
    options: IngestOptions
    twice: int = 0  # points overlapping tiles held twice, dropped
    totals: Totals = field(default_factory=Totals)

    def add(self, r: BlockResult | None) -> None:
        if r is None:
            return
        self.totals.add(r)
        self.writer.add(
            levels=r.levels,
            points=r.points,
            evidence=r.evidence,
            objects=(r.trees, r.buildings) if self.options.objects else None,
        )

    def describe(self, bounds: Box) -> None:
        """The version's parameters and figures, once every block is in."""
        t, o = self.totals, self.options
        if not t.blocks:
            raise InputError("the survey holds no points to model")
        params = {
            "method": str(o.method),
            "resolution": o.resolution,
            "subgrid": SUBGRID,
            "flat_threshold": t.flat_threshold,
            "density": o.density,
            "exclude_classes": list(o.exclude),
            "blocks": t.blocks,
            "finest_level": min(t.tiles),
        }
        if t.peak_mib:  # modelled in worker processes
            params["worker_peak_mib"] = t.peak_mib
        if self.twice:
            params["overlap_points_dropped"] = self.twice
        self.writer.describe(params=params, stats=t.stats(bounds).to_json())


@dataclass(frozen=True)
class _Kept:
    """Where a modelled block goes: kept on disk for a resumed run, and into the version."""

    spool: Spool
    store: _Store

    def __call__(self, k: int, r: BlockResult | None) -> None:
        self.spool.put(k, r)
        self.store.add(r)
