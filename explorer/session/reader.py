"""Reading a session directory back, up to the last complete record of every file."""
from __future__ import annotations

import warnings
from pathlib import Path, PurePosixPath

import numpy as np

from explorer.session.codec import parse_contact, parse_csv_table, parse_event, parse_json_record
from explorer.session.errors import SessionFormatError, SessionTruncatedWarning
from explorer.session.layout import (
    CONTACTS_FILE,
    EVENTS_FILE,
    JOINT_STATES_FILE,
    READINGS_COLUMNS,
    READINGS_FILE,
    RECONSTRUCTIONS_FILE,
    RECORD_FILES,
    dof_from_joint_state_columns,
)
from explorer.session.line_files import partial_tail_bytes, read_complete_lines
from explorer.session.metadata import load_metadata
from explorer.session.records import Event, JointStates, Readings, ReconstructionSnapshot, Session
from sensor.oriented_contact import OrientedContact


def read_session(directory: str | Path) -> Session:
    """Read a whole session; see :meth:`SessionReader.read`."""
    return SessionReader(directory).read()


def _check_time_order(path: Path, t_s: np.ndarray) -> None:
    """Time stamps (column 1, rows from line 2) must be finite and non-decreasing."""
    bad = np.flatnonzero(~np.isfinite(t_s))
    if bad.size:
        raise SessionFormatError(path, int(bad[0]) + 2, f"time stamp is not finite: {t_s[bad[0]]!r}")
    backwards = np.flatnonzero(np.diff(t_s) < 0)
    if backwards.size:
        row = int(backwards[0]) + 1
        raise SessionFormatError(
            path, row + 2, f"time stamp {t_s[row]!r} is earlier than the previous one {t_s[row - 1]!r}"
        )


class SessionReader:
    """Reads the files of a session directory.

    Each method reads its file up to the last complete line. A file whose final line is cut off
    (the run was killed while writing it) is read without that line and reported: it is listed in
    :attr:`truncated_files` and a :class:`SessionTruncatedWarning` names it. A malformed line
    anywhere else raises :class:`SessionFormatError` with the file and line number.

    Parameters
    ----------
    directory : str or Path
        A session directory written by :class:`~explorer.session.writer.SessionWriter`.

    Raises
    ------
    FileNotFoundError
        When ``directory`` holds no ``metadata.json``.
    SessionFormatError
        When the metadata is unreadable or of an unsupported format version.
    """

    def __init__(self, directory: str | Path):
        self.directory = Path(directory)
        self.metadata = load_metadata(self.directory)

    @property
    def truncated_files(self) -> tuple[str, ...]:
        """Names of the record files that end in an incomplete line."""
        return tuple(name for name in RECORD_FILES if partial_tail_bytes(self.directory / name))

    def _complete_lines(self, name: str) -> list[str]:
        path = self.directory / name
        content = read_complete_lines(path)
        if content.partial_tail_bytes:
            warnings.warn(
                f"{path}: ends in an incomplete record of {content.partial_tail_bytes} bytes "
                f"(the run was killed while writing it); read up to the last complete record",
                SessionTruncatedWarning,
                stacklevel=3,
            )
        return content.lines

    def readings(self) -> Readings:
        """The raw sensor stream (``readings.csv``)."""
        path = self.directory / READINGS_FILE
        rows = parse_csv_table(path, self._complete_lines(READINGS_FILE), READINGS_COLUMNS)
        _check_time_order(path, rows[:, 0])
        return Readings.from_rows(rows)

    def joint_states(self) -> JointStates:
        """Joint positions over time (``joint_states.csv``; empty when the run logged none)."""
        path = self.directory / JOINT_STATES_FILE
        lines = self._complete_lines(JOINT_STATES_FILE)
        if not lines:
            return JointStates.from_rows(np.empty((0, 1)), dof=0)
        dof = dof_from_joint_state_columns(lines[0].split(","))
        if dof is None:
            raise SessionFormatError(path, 1, f"header must be 't_s,q0,...,q<dof-1>', got {lines[0]!r}")
        rows = parse_csv_table(path, lines, tuple(lines[0].split(",")))
        _check_time_order(path, rows[:, 0])
        return JointStates.from_rows(rows, dof)

    def contacts(self, readings: Readings | None = None) -> tuple[OrientedContact, ...]:
        """Detected contacts (``contacts.jsonl``), each with its readings taken from the raw stream.

        Parameters
        ----------
        readings : Readings, optional
            The session's raw stream when already read (it is read otherwise).
        """
        path = self.directory / CONTACTS_FILE
        lines = self._complete_lines(CONTACTS_FILE)
        if readings is None and lines:
            readings = self.readings()
        contacts = []
        for line_number, line in enumerate(lines, start=1):
            contact, time_range, n_readings = parse_contact(path, line_number, line)
            if time_range is None:
                if n_readings != 0:
                    raise SessionFormatError(path, line_number, "n_readings > 0 but readings_t_s is null")
                contacts.append(contact)
                continue
            first = int(np.searchsorted(readings.t_s, time_range[0], side="left"))
            end = int(np.searchsorted(readings.t_s, time_range[1], side="right"))
            if end - first != n_readings:
                raise SessionFormatError(
                    path,
                    line_number,
                    f"references {n_readings} readings in t_s [{time_range[0]!r}, {time_range[1]!r}] "
                    f"but {READINGS_FILE} holds {end - first} there",
                )
            contacts.append(
                OrientedContact(
                    t_s=contact.t_s,
                    position_m=contact.position_m,
                    normal=contact.normal,
                    force_n=contact.force_n,
                    readings=tuple(readings[i] for i in range(first, end)),
                )
            )
        return tuple(contacts)

    def events(self) -> tuple[Event, ...]:
        """Events in the order they were written (``events.jsonl``)."""
        path = self.directory / EVENTS_FILE
        lines = self._complete_lines(EVENTS_FILE)
        return tuple(parse_event(path, number, line) for number, line in enumerate(lines, start=1))

    def reconstructions(self) -> tuple[ReconstructionSnapshot, ...]:
        """Reconstruction snapshots (``reconstructions.jsonl``), paths resolved and checked to exist."""
        path = self.directory / RECONSTRUCTIONS_FILE
        snapshots = []
        for line_number, line in enumerate(self._complete_lines(RECONSTRUCTIONS_FILE), start=1):
            record = parse_json_record(
                path,
                line_number,
                line,
                {"t_s": float, "n_contacts": int, "path": str, "n_vertices": int, "n_faces": int},
            )
            relative = PurePosixPath(record["path"])
            if relative.is_absolute() or ".." in relative.parts:
                problem = f"path must stay inside the session: {record['path']!r}"
                raise SessionFormatError(path, line_number, problem)
            mesh_path = self.directory.joinpath(*relative.parts)
            if not mesh_path.is_file():
                raise SessionFormatError(path, line_number, f"snapshot file {mesh_path} is missing")
            snapshots.append(
                ReconstructionSnapshot(
                    t_s=float(record["t_s"]),
                    n_contacts=record["n_contacts"],
                    path=mesh_path,
                    n_vertices=record["n_vertices"],
                    n_faces=record["n_faces"],
                )
            )
        return tuple(snapshots)

    def read(self) -> Session:
        """Everything in the session, up to the last complete record of each file."""
        truncated = self.truncated_files
        readings = self.readings()
        return Session(
            directory=self.directory,
            metadata=self.metadata,
            readings=readings,
            joint_states=self.joint_states(),
            contacts=self.contacts(readings),
            events=self.events(),
            reconstructions=self.reconstructions(),
            truncated_files=truncated,
        )
