"""The one progress protocol of long work: a callable told the step, its units done and its total.

Library functions that take a while accept ``progress: Progress | None``; they call it as each
step starts (``done`` 0) and as its units finish. A total of 0 means the step's size is not
known in advance. What to show is the caller's choice: the command line draws bars
(:mod:`tdb.cli.progress`), a notebook or a service may log or ignore it.
"""

from __future__ import annotations

from typing import Protocol


class Progress(Protocol):
    """``progress(step, done, total)``."""

    def __call__(self, step: str, done: int, total: int) -> None: ...


def silent(step: str, done: int, total: int) -> None:
    """A :class:`Progress` that shows nothing."""


def or_silent(progress: Progress | None) -> Progress:
    """``progress``, or :func:`silent` where none is given."""
    return progress if progress is not None else silent


def labelled(progress: Progress | None, label: str) -> Progress | None:
    """``progress`` with each step named after ``label`` too: the same steps of several runs
    (the intervals of a history) told apart. None where ``progress`` is."""
    if progress is None:
        return None
    told = progress

    def report(step: str, done: int, total: int) -> None:
        told(f"{step} ({label})", done, total)

    return report
