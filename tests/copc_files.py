"""COPC files for the range-read tests and benchmark, written with copclib (tdb only reads COPC).

The octree is the usual one for airborne data: each point goes to a depth drawn at random, the
deeper the likelier (four times per level, since airborne points spread in plan), and to the
node of that depth holding it; so every level is a thinned copy of the whole survey and the
deepest holds most points, as a COPC writer such as untwine makes it.
"""

from __future__ import annotations

from pathlib import Path

import laspy
import numpy as np

from tdb.cloud import PointCloud

SCALE = 0.001  # m
LEAF_POINTS = 20_000  # about this many points in a node of the deepest level


def write_copc(path: Path, cloud: PointCloud, *, depth: int | None = None, seed: int = 0) -> Path:
    """Write ``cloud`` as a COPC file of ``depth`` + 1 octree levels (default: deep enough for
    about :data:`LEAF_POINTS` points per node of the deepest level); returns ``path``."""
    import copclib as copc

    xyz = cloud.xyz
    lo, hi = xyz.min(axis=0), xyz.max(axis=0)
    half = float((hi - lo).max() / 2 + 1.0)
    centre = (lo + hi) / 2
    wkt = cloud.crs.to_wkt() if cloud.crs is not None else ""
    config = copc.CopcConfigWriter(6, copc.Vector3(SCALE, SCALE, SCALE), copc.Vector3(*map(float, lo)), wkt)
    config.copc_info.center_x, config.copc_info.center_y, config.copc_info.center_z = map(float, centre)
    config.copc_info.halfsize = half
    config.copc_info.spacing = 2 * half / 128
    config.las_header.min = copc.Vector3(*map(float, lo))
    config.las_header.max = copc.Vector3(*map(float, hi))
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales, header.offsets = np.full(3, SCALE), lo
    rec = laspy.ScaleAwarePointRecord.zeros(len(xyz), header=header)
    rec.x, rec.y, rec.z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    rec.classification = cloud.classification
    rec.return_number, rec.number_of_returns = cloud.return_number, cloud.number_of_returns
    if depth is None:
        depth = max(1, int(np.ceil(np.log(max(len(xyz), 1) / LEAF_POINTS) / np.log(4))))
    # three quarters of the points at the deepest level, a quarter of the rest one level up, ...
    level = depth - np.minimum(np.random.default_rng(seed).geometric(0.75, len(xyz)) - 1, depth)
    cell = np.floor((xyz - (centre - half)) / (2 * half / 2.0**depth)).astype(np.int64)
    cell >>= (depth - level)[:, None]
    _with_parents(level, cell, depth)
    keys, node = np.unique(np.column_stack([level, cell]), axis=0, return_inverse=True)
    node = node.ravel()
    order = np.argsort(node, kind="stable")
    start = np.r_[0, np.cumsum(np.bincount(node, minlength=len(keys)))]
    packed = rec.array[order]
    writer = copc.FileWriter(str(path), config)
    for k, (d, x, y, z) in enumerate(keys.tolist()):
        data = np.frombuffer(packed[start[k] : start[k + 1]].tobytes(), np.int8)
        writer.AddNode(copc.VoxelKey(d, x, y, z), copc.VectorChar(data))
    writer.Close()
    return path


def _with_parents(level: np.ndarray, cell: np.ndarray, depth: int) -> None:
    """Move one point up wherever a node's parent holds none: readers reach a node only through
    its parents."""
    for d in range(depth, 0, -1):
        here = np.flatnonzero(level == d)
        parent = cell[here] >> 1
        above = {tuple(k) for k in cell[level == d - 1].tolist()}
        missing = np.array([tuple(k) not in above for k in parent.tolist()], bool)
        _, first = np.unique(parent[missing], axis=0, return_index=True)
        moved = here[np.flatnonzero(missing)[first]]
        level[moved] = d - 1
        cell[moved] >>= 1
