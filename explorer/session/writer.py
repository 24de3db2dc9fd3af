"""Recording a run as it happens: one append-only line per record, crash-safe."""
from __future__ import annotations

import threading
import warnings
from array import array
from bisect import bisect_left, bisect_right
from pathlib import Path
from typing import Any


from explorer.session.codec import (
    as_count,
    as_float,
    encode_contact,
    encode_event,
    encode_joint_state,
    encode_reading,
)
from explorer.session.errors import SessionClosedError, SessionTruncatedWarning
from explorer.session.layout import (
    CONTACTS_FILE,
    EVENTS_FILE,
    JOINT_STATES_FILE,
    READINGS_COLUMNS,
    READINGS_FILE,
    RECONSTRUCTIONS_DIR,
    RECONSTRUCTIONS_FILE,
    RECORD_FILES,
    joint_state_columns,
    reconstruction_file_name,
)
from explorer.session.line_files import AppendOnlyFile, cut_partial_tail, fsync_directory, read_complete_lines
from explorer.session.metadata import (
    caller_metadata,
    caller_part,
    load_metadata,
    new_metadata,
    save_metadata,
    utc_now,
)
from common.plain_json import dumps_line
from explorer.session.ply import mesh_arrays, write_ply
from explorer.session.reader import SessionReader
from explorer.session.records import ReconstructionSnapshot
from sensor.oriented_contact import OrientedContact
from sensor.reading import Reading


class SessionWriter:
    """Appends everything a run sees to a session directory, record by record.

    Every record is one line handed to the operating system before the ``write_*`` call returns,
    so a run that is killed (even by SIGKILL) leaves a session readable up to its last record.
    Contacts, events and reconstruction snapshots are also fsynced (they are rare and precious);
    the high-rate readings and joint states are not, unless ``fsync_streams=True``: without it a
    power loss (not a process crash) can lose their last few seconds.

    Parameters
    ----------
    directory : str or Path
        Session directory; created when missing. A directory that already holds files is refused
        unless ``resume=True``.
    metadata : dict, optional
        Run description: must hold ``robot``, ``sensor``, ``object`` and ``seed`` (None allowed),
        plus anything else JSON can hold (``configuration``, ...; numpy values are converted).
        Required for a new session; with ``resume=True`` it may be omitted, and when given it
        must equal the stored description.
    resume : bool
        Append to the existing session in ``directory``. An incomplete final line left by a
        crash is cut off first (with a warning, and noted in the metadata's ``resumed`` list).
    fsync_streams : bool
        Also fsync after every reading and joint state (durable against power loss, slower).

    Notes
    -----
    Readings and joint states must arrive in time order (non-decreasing ``t_s``); a contact's
    readings must have been written with :meth:`write_reading` first, since the contact refers to
    them by time range instead of storing them again. The methods may be called from several
    threads.
    """

    def __init__(
        self,
        directory: str | Path,
        metadata: dict | None = None,
        *,
        resume: bool = False,
        fsync_streams: bool = False,
    ):
        self.directory = Path(directory)
        self._fsync_streams = bool(fsync_streams)
        self._lock = threading.Lock()
        self._closed = False
        self._reading_times = array("d")
        self._last_joint_time: float | None = None
        self._dof: int | None = None
        self._n_reconstructions = 0
        if resume:
            self._metadata = self._prepare_resume(metadata)
        else:
            self._metadata = self._prepare_new(metadata)
        self._readings = self._open_csv(READINGS_FILE, READINGS_COLUMNS)
        self._joint_states: AppendOnlyFile | None = None
        if self._dof is not None:
            self._joint_states = AppendOnlyFile(self.directory / JOINT_STATES_FILE)
        self._contacts = AppendOnlyFile(self.directory / CONTACTS_FILE)
        self._events = AppendOnlyFile(self.directory / EVENTS_FILE)
        self._reconstructions = AppendOnlyFile(self.directory / RECONSTRUCTIONS_FILE)
        (self.directory / RECONSTRUCTIONS_DIR).mkdir(exist_ok=True)
        fsync_directory(self.directory)

    # ------------------------------------------------------------------------ opening
    def _prepare_new(self, metadata: dict | None) -> dict:
        if metadata is None:
            raise ValueError("metadata is required to start a new session (omit it only with resume=True)")
        if self.directory.exists() and (not self.directory.is_dir() or any(self.directory.iterdir())):
            raise FileExistsError(
                f"{self.directory} already exists and is not an empty directory; pass resume=True "
                f"to append to the session there, or choose a new directory"
            )
        full = new_metadata(metadata)
        self.directory.mkdir(parents=True, exist_ok=True)
        save_metadata(self.directory, full)
        return full

    def _prepare_resume(self, metadata: dict | None) -> dict:
        stored = load_metadata(self.directory)
        if metadata is not None:
            given, kept = caller_metadata(metadata), caller_part(stored)
            differing = sorted(key for key in given.keys() | kept.keys() if given.get(key) != kept.get(key))
            if differing:
                raise ValueError(f"metadata differs from the session being resumed in {differing}")
        discarded = {}
        for name in RECORD_FILES:
            cut = cut_partial_tail(self.directory / name)
            if cut:
                discarded[name] = cut
        if discarded:
            warnings.warn(
                f"{self.directory}: resuming after a crash, incomplete final records cut off "
                f"(bytes per file): {discarded}",
                SessionTruncatedWarning,
                stacklevel=3,
            )
        reader = SessionReader(self.directory)
        self._reading_times.extend(reader.readings().t_s)
        joint_states = reader.joint_states()
        if joint_states.dof:
            self._dof = joint_states.dof
            self._last_joint_time = float(joint_states.t_s[-1]) if len(joint_states) else None
        self._n_reconstructions = len(read_complete_lines(self.directory / RECONSTRUCTIONS_FILE).lines)
        stored.update(end_time_utc=None, end_status="open", end_error=None)
        stored["resumed"] = stored.get("resumed", []) + [
            {"time_utc": utc_now(), "discarded_partial_bytes": discarded}
        ]
        save_metadata(self.directory, stored)
        return stored

    def _open_csv(self, name: str, columns: tuple[str, ...]) -> AppendOnlyFile:
        """Open a CSV stream for appending, writing its header when the file is new or empty."""
        stream = AppendOnlyFile(self.directory / name)
        if stream.size() == 0:
            stream.append(",".join(columns), fsync=True)
        return stream

    # ------------------------------------------------------------------------ writing
    def _check_open(self) -> None:
        if self._closed:
            raise SessionClosedError(
                f"the session writer for {self.directory} is closed; no more records can be written"
            )

    @property
    def closed(self) -> bool:
        """True once :meth:`close` has run."""
        return self._closed

    def write_reading(self, reading: Reading) -> None:
        """Append one raw sensor reading (``readings.csv``).

        Raises
        ------
        ValueError
            Wrong shapes, a non-finite ``t_s``, or a ``t_s`` earlier than the previous reading's.
        """
        t_s, row = encode_reading(reading)
        with self._lock:
            self._check_open()
            if self._reading_times and t_s < self._reading_times[-1]:
                raise ValueError(
                    f"reading.t_s {t_s!r} is earlier than the previous reading's "
                    f"{self._reading_times[-1]!r}; readings must be written in time order"
                )
            self._readings.append(row, fsync=self._fsync_streams)
            self._reading_times.append(t_s)

    def write_joint_state(self, t_s: float, q: Any) -> None:
        """Append the joint positions ``q`` ((dof,) radians) measured at ``t_s`` seconds.

        The first call fixes the session's dof. Raises ValueError on a shape change, a
        non-finite or backwards ``t_s``.
        """
        with self._lock:
            self._check_open()
            t_s, q, row = encode_joint_state(t_s, q, self._dof)
            if self._last_joint_time is not None and t_s < self._last_joint_time:
                raise ValueError(
                    f"t_s {t_s!r} is earlier than the previous joint state's {self._last_joint_time!r}; "
                    f"joint states must be written in time order"
                )
            if self._joint_states is None:
                self._dof = len(q)
                self._joint_states = self._open_csv(JOINT_STATES_FILE, joint_state_columns(self._dof))
            self._joint_states.append(row, fsync=self._fsync_streams)
            self._last_joint_time = t_s

    def write_contact(self, contact: OrientedContact) -> None:
        """Append a detected contact (``contacts.jsonl``, fsynced).

        Its ``readings`` are not stored again: the record refers to them by their time range,
        so they must already have been written with :meth:`write_reading`.

        Raises
        ------
        ValueError
            Non-finite values or wrong shapes (naming the field), a non-unit normal, or readings
            that are not in the raw stream.
        """
        record = encode_contact(contact)
        with self._lock:
            self._check_open()
            if record["readings_t_s"] is not None:
                t_first, t_last = record["readings_t_s"]
                times = self._reading_times
                in_stream = bisect_right(times, t_last) - bisect_left(times, t_first)
                if in_stream != record["n_readings"]:
                    raise ValueError(
                        f"contact.readings: {record['n_readings']} readings in t_s [{t_first!r}, "
                        f"{t_last!r}] but {in_stream} written with write_reading there; write a "
                        f"contact's readings to the session first (it refers to them by time range)"
                    )
                # The referenced readings must be on disk before the contact that refers to them.
                self._readings.fsync()
            self._contacts.append(dumps_line(record), fsync=True)

    def write_event(self, kind: str, t_s: float, **fields: Any) -> None:
        """Append an event (``events.jsonl``, fsynced).

        Parameters
        ----------
        kind : str
            Lower-case identifier. Standard kinds and their required fields: ``contact_start``,
            ``contact_end``; ``touch`` and ``miss`` (``target_m`` (3,) world frame, metres;
            ``approach_dir`` (3,) world frame, unit); ``error`` (``source``, ``message``: str).
        t_s : float
            Time, seconds, on the readings' clock.
        **fields
            JSON-storable values (numpy arrays and scalars are converted; floats must be finite).
        """
        record = encode_event(kind, t_s, fields)
        with self._lock:
            self._check_open()
            self._events.append(dumps_line(record), fsync=True)

    def write_reconstruction(self, mesh: Any, n_contacts: int, t_s: float) -> ReconstructionSnapshot:
        """Save a reconstruction snapshot: a PLY file plus a line in ``reconstructions.jsonl``.

        Parameters
        ----------
        mesh : trimesh.Trimesh or (vertices (n, 3) float metres, faces (m, 3) int)
            The reconstructed surface, world frame.
        n_contacts : int
            Number of contacts the reconstruction was fitted to.
        t_s : float
            Time of the snapshot, seconds.

        Returns
        -------
        ReconstructionSnapshot
            What a reader will find for this snapshot.
        """
        vertices, faces = mesh_arrays(mesh)
        n_contacts = as_count(n_contacts, "n_contacts")
        t_s = as_float(t_s, "t_s")
        with self._lock:
            self._check_open()
            relative = reconstruction_file_name(self._n_reconstructions)
            path = self.directory / relative
            write_ply(path, vertices, faces)
            record = {
                "t_s": t_s,
                "n_contacts": n_contacts,
                "path": relative,
                "n_vertices": len(vertices),
                "n_faces": len(faces),
            }
            self._reconstructions.append(dumps_line(record), fsync=True)
            self._n_reconstructions += 1
        return ReconstructionSnapshot(t_s, n_contacts, path, len(vertices), len(faces))

    # ------------------------------------------------------------------------ closing
    def close(self, error: BaseException | None = None) -> None:
        """Flush everything to disk and mark the session ended. Idempotent.

        Parameters
        ----------
        error : BaseException, optional
            The exception that ended the run; the metadata then says ``end_status: "aborted"``.
        """
        with self._lock:
            if self._closed:
                return
            self._closed = True
            for stream in (
                self._readings, self._joint_states, self._contacts, self._events, self._reconstructions
            ):
                if stream is not None:
                    stream.fsync()
                    stream.close()
            self._metadata.update(
                end_time_utc=utc_now(),
                end_status="closed" if error is None else "aborted",
                end_error=None if error is None else f"{type(error).__name__}: {error}",
            )
            save_metadata(self.directory, self._metadata)

    def __enter__(self) -> "SessionWriter":
        return self

    def __exit__(self, exc_type, exc, traceback) -> None:
        self.close(error=exc)

    def __repr__(self) -> str:
        state = "closed" if self._closed else "open"
        return f"SessionWriter({str(self.directory)!r}, {state}, {len(self._reading_times)} readings)"
