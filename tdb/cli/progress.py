"""Progress bars on the terminal: the command line's :class:`tdb.progress.Progress`."""

from __future__ import annotations

import contextlib
import warnings
from collections.abc import Iterator
from types import TracebackType
from typing import Any

from tqdm import tqdm

from tdb.errors import TdbWarning

BAR = "{desc} {bar} {n_fmt}/{total_fmt} [{elapsed}<{remaining}, {rate_fmt}]"
COUNT = "{desc} {n_fmt} [{elapsed}]"  # a step whose size is not known


class Bars:
    """One bar per step, replaced as the steps follow one another; a context manager that closes
    the last bar. Hidden where stderr is not a terminal (``disable=None``)."""

    def __init__(self, *, unit: str = "it", leave: bool = False) -> None:
        self.unit = unit
        self.leave = leave
        self._bar: Any = None
        self._step: str | None = None

    def __call__(self, step: str, done: int, total: int) -> None:
        if step != self._step or self._bar is None:
            self.close()
            self._step = step
            self._bar = tqdm(
                total=total or None,
                desc=f"{step:<26}",
                unit=self.unit,
                leave=self.leave,
                disable=None,
                bar_format=BAR if total else COUNT,
                unit_scale=True,
            )
        if total and self._bar.total != total:
            self._bar.total = total
        self._bar.update(done - self._bar.n)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> Bars:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()


@contextlib.contextmanager
def echo_warnings() -> Iterator[None]:
    """Library warnings (:class:`tdb.errors.TdbWarning`) as one ``tdb: warning:`` line each on
    stderr, each message once however many blocks said it; other warnings pass on as they were."""
    import click

    caught: list[warnings.WarningMessage] = []
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", TdbWarning)
            yield
    finally:
        said: set[str] = set()
        for w in caught:  # outside the recording, so passing one on does not record it again
            if not issubclass(w.category, TdbWarning):
                warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
            elif str(w.message) not in said:
                said.add(str(w.message))
                click.echo(f"tdb: warning: {w.message}", err=True)
