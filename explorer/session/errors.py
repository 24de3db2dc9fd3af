"""Exceptions and warnings of the session format."""
from __future__ import annotations

from pathlib import Path


class SessionFormatError(ValueError):
    """A session file holds something that is not a crash artefact: a bad line, header or version.

    Attributes
    ----------
    path : Path
        The offending file.
    line_number : int or None
        1-based line number in ``path``, None when the problem is not tied to one line.
    """

    def __init__(self, path: Path, line_number: int | None, problem: str):
        self.path = Path(path)
        self.line_number = line_number
        where = f"{self.path}" if line_number is None else f"{self.path}, line {line_number}"
        super().__init__(f"{where}: {problem}")


class SessionClosedError(RuntimeError):
    """A write was attempted on a :class:`SessionWriter` that has been closed."""


class SessionTruncatedWarning(UserWarning):
    """A session file ends in an incomplete line (the run was killed while writing it)."""
