"""The on-disk session: an append-only, crash-safe record of everything a run saw.

Write with :class:`SessionWriter`, read with :func:`read_session` / :class:`SessionReader`.
The format is documented in ``docs/SESSION_FORMAT.md`` and can be read without this package.
"""
from explorer.session.errors import SessionClosedError, SessionFormatError, SessionTruncatedWarning
from explorer.session.layout import FORMAT_VERSION
from explorer.session.reader import SessionReader, read_session
from explorer.session.records import Event, JointStates, Readings, ReconstructionSnapshot, Session
from explorer.session.writer import SessionWriter

__all__ = [
    "FORMAT_VERSION",
    "Event",
    "JointStates",
    "Readings",
    "ReconstructionSnapshot",
    "Session",
    "SessionClosedError",
    "SessionFormatError",
    "SessionReader",
    "SessionTruncatedWarning",
    "SessionWriter",
    "read_session",
]
