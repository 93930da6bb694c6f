"""What stands on the ground (seed §2.2–2.3): vegetation and buildings, individual trees.

:func:`find_objects` is the whole step: the points' classes, the buildings' footprints and
the trees, from a cloud, its ground mask and its dense ground model.
"""

from ingest.objects.by_blocks import FoundObjects, objects_by_blocks, objects_of
from ingest.objects.cover import CoverParams, classify_cover
from ingest.objects.find import ObjectParams, Objects, find_objects, survey_objects
from ingest.objects.trees import TreeParams, find_trees

__all__ = [
    "CoverParams",
    "FoundObjects",
    "ObjectParams",
    "Objects",
    "TreeParams",
    "classify_cover",
    "find_objects",
    "find_trees",
    "objects_by_blocks",
    "objects_of",
    "survey_objects",
]
