"""Synthetic LiDAR scenes with exact ground truth (``tdb synth``)."""

from ingest.synth.changes import Change, apply_changes
from ingest.synth.sampling import iter_samples, sample
from ingest.synth.scene import Scene, make_scene
from ingest.synth.surface import ground_grid, ground_height
from ingest.synth.truth import changes_truth, scene_truth
from ingest.synth.writer import write_scene

__all__ = [
    "Change",
    "Scene",
    "apply_changes",
    "changes_truth",
    "ground_grid",
    "ground_height",
    "iter_samples",
    "make_scene",
    "sample",
    "scene_truth",
    "write_scene",
]
