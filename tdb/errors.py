"""One hierarchy of library errors, all under :class:`TdbError`.

Builtins are mixed in where the meaning fits, so callers that already catch
``OSError`` or ``ValueError`` keep working.
"""

from __future__ import annotations

from enum import Enum


class Remedy(str, Enum):
    """What the caller can do about an error; each front end phrases it in its own terms
    (the command line names its flags), so library messages name none."""

    REPLACE = "replace"  # write over the existing version
    GIVE_CRS = "give_crs"  # name the coordinate system, or declare the coordinates metres
    BLOCKS = "blocks"  # model the survey block by block


class TdbError(Exception):
    """Base class of every error raised by tdb.

    ``remedy``, where set, says what the caller can do about it (:class:`Remedy`).
    """

    def __init__(self, *args: object, remedy: Remedy | None = None) -> None:
        super().__init__(*args)
        self.remedy = remedy


class TdbIOError(TdbError, OSError):
    """A file is missing, unreadable or cannot be written."""


class FormatError(TdbError, ValueError):
    """A file is not in the format it claims: truncated, corrupt or malformed."""


class InputError(TdbError, ValueError):
    """Input data cannot be used: empty, non-finite or out of range."""


class DegenerateInputError(InputError):
    """Points span no area: fewer than three, all identical or collinear."""


class CRSError(TdbError, ValueError):
    """A coordinate reference system is missing, unknown or unusable."""


class OptionError(TdbError, ValueError):
    """A string option is not one of the registered choices."""


class DatabaseError(TdbError):
    """A terrain database is damaged, foreign or used wrongly."""


class VersionExistsError(DatabaseError):
    """A version name is already taken in the database."""


class VersionNotFoundError(DatabaseError, KeyError):
    """A version name is not in the database."""

    def __str__(self) -> str:  # KeyError quotes its message; keep it plain
        return str(self.args[0]) if self.args else ""


class ResumeError(TdbError):
    """An interrupted ingest cannot be resumed: none was left, or it was another run."""


class QueryError(TdbError, ValueError):
    """A query cannot be parsed or run; ``line`` and ``column`` locate parse errors."""

    def __init__(self, message: str, *, text: str | None = None, position: int | None = None):
        self.text = text
        self.position = position
        self.line: int | None = None
        self.column: int | None = None
        if text is not None and position is not None:
            before = text[:position]
            self.line = before.count("\n") + 1
            self.column = position - (before.rfind("\n") + 1) + 1
            source_line = text.splitlines()[self.line - 1] if text.strip() else ""
            caret = " " * (self.column - 1) + "^"
            message = f"{message} at line {self.line}, column {self.column}\n  {source_line}\n  {caret}"
        super().__init__(message)


class FilterError(TdbError, ValueError):
    """A feature filter definition is invalid."""


class TdbWarning(UserWarning):
    """Something tdb did differently from what was asked, or could not do, and went on without."""
