"""Writing a run as it happens: the session record and ``contacts.csv``.

Every contact is appended (and fsynced) to ``contacts.csv`` in the object frame the moment it is
recorded, and the raw stream goes to the session directory (:mod:`explorer.session`), so a run
killed halfway keeps every contact it made.

A resumed run (:mod:`explorer.resume`) appends to the same files. Its devices' clocks usually
start again from zero, so the recorder adds ``time_offset_s`` to every time it writes: the session
clock goes on from where the stopped part ended and stays non-decreasing.
"""
from __future__ import annotations

import dataclasses
import math
import os
from pathlib import Path

import numpy as np

from explorer.loop import Recorder
from explorer.observer import RunObserver
from explorer.touch import TouchOutcome
from explorer.session import SessionWriter

CONTACTS_HEADER = "touch,x,y,z,nx,ny,nz,t_s,force_n,stand_yaw_rad,stand_tilt_rad,doubtful\n"


class RunRecorder(Recorder):
    """Records a run into ``out_dir``: ``session/`` and ``contacts.csv``.

    Parameters
    ----------
    out_dir : Path
    metadata : dict
        Session metadata (robot, sensor, object, seed, configuration).
    resume : bool
        Append to the run already in ``out_dir`` instead of refusing to overwrite it; the
        stored session metadata is kept (``metadata`` is then not checked against it).
    time_offset_s : float
        Added to every time written (device clock -> session clock), seconds.
    observer : RunObserver, optional
        Shown everything the recorder writes, on the session clock, after it is written.
    """

    def __init__(self, out_dir: Path, metadata: dict, resume: bool = False, time_offset_s: float = 0.0,
                 observer: RunObserver | None = None):
        if not math.isfinite(time_offset_s):
            raise ValueError(f"time_offset_s must be finite, got {time_offset_s!r}")
        self.out_dir = Path(out_dir)
        self.out_dir.mkdir(parents=True, exist_ok=True)
        self.time_offset_s = float(time_offset_s)
        self.latest_time_s = 0.0  # the latest device time handed to the recorder, seconds
        self.observer = observer or RunObserver()
        self.session = SessionWriter(self.out_dir / "session", None if resume else metadata, resume=resume)
        path = self.out_dir / "contacts.csv"
        fresh = not path.exists() or not resume
        self._contacts = open(path, "w" if fresh else "a", encoding="utf-8")
        if fresh:
            self._contacts.write(CONTACTS_HEADER)
            self._flush()

    def readings(self, readings) -> None:
        shifted = [self._shifted(reading) for reading in readings]
        for reading, original in zip(shifted, readings):
            self.session.write_reading(reading)
            self._saw(original.t_s)
        self.observer.readings(shifted)

    def joint_state(self, t_s: float, q: np.ndarray) -> None:
        self.session.write_joint_state(t_s + self.time_offset_s, q)
        self._saw(t_s)
        self.observer.joint_state(t_s + self.time_offset_s, q)

    def touch(self, record: TouchOutcome) -> None:
        kind = "touch" if record.kind == "contact" else ("miss" if record.kind == "miss" else record.kind)
        fields = dict(target_m=record.target_m.tolist(), approach_dir=record.approach_dir.tolist(),
                      index=record.index, result=record.kind, strategy=record.strategy,
                      stand_yaw_rad=record.stand_yaw_rad, stand_tilt_rad=record.stand_tilt_rad)
        if record.press_t_s is not None:
            fields["press_t_s"] = [t + self.time_offset_s for t in record.press_t_s]
        if record.repress_t_s is not None:
            fields["repress_t_s"] = record.repress_t_s + self.time_offset_s
        if record.position_m is not None:  # also for contacts set aside for a realign touch
            fields.update(position_m=record.position_m.tolist(), normal=record.normal.tolist())
        if record.contact is not None:
            fields["force_n"] = record.contact.force_n
        if record.quality is not None:
            fields["quality"] = quality_fields(record.quality)
        if record.free_space_m is not None:
            fields["free_space_m"] = np.asarray(record.free_space_m).tolist()
        if record.side_m is not None:
            fields["side_m"] = np.asarray(record.side_m).tolist()
        if record.left_line_m is not None:
            fields["left_line_m"] = np.asarray(record.left_line_m).tolist()
        self.session.write_event(kind, record.t_s + self.time_offset_s, **fields)
        self._saw(record.t_s)
        if record.kind == "contact":
            contact = self._shifted_contact(record.contact)
            self.session.write_contact(contact)
            self._contacts.write(contacts_csv_row(record, contact.t_s, contact.force_n))
            self._flush()
        self.observer.touch(record, record.t_s + self.time_offset_s)

    def event(self, kind: str, t_s: float, **fields) -> None:
        self.session.write_event(kind, t_s + self.time_offset_s, **fields)
        self._saw(t_s)
        self.observer.event(kind, t_s + self.time_offset_s, fields)

    def reconstruction(self, mesh, n_contacts: int, t_s: float) -> None:
        self.session.write_reconstruction(mesh, n_contacts, t_s + self.time_offset_s)
        self.observer.reconstruction(mesh, n_contacts, t_s + self.time_offset_s)

    def _saw(self, t_s: float) -> None:
        self.latest_time_s = max(self.latest_time_s, float(t_s))

    def _shifted(self, reading):
        if not self.time_offset_s:
            return reading
        return dataclasses.replace(reading, t_s=reading.t_s + self.time_offset_s)

    def _shifted_contact(self, contact):
        if not self.time_offset_s:
            return contact
        return dataclasses.replace(contact, t_s=contact.t_s + self.time_offset_s,
                                   readings=tuple(self._shifted(r) for r in contact.readings))

    def close(self, error: BaseException | None = None) -> None:
        try:
            self.observer.close()
        except Exception as exc:  # noqa: BLE001 - a viewer that failed must not cost the records
            import warnings

            warnings.warn(f"the run observer failed to close: {type(exc).__name__}: {exc}", RuntimeWarning)
        if not self._contacts.closed:
            self._contacts.close()
        if not self.session.closed:
            self.session.close(error=error)

    def _flush(self) -> None:
        self._contacts.flush()
        os.fsync(self._contacts.fileno())


def contacts_csv_row(record: TouchOutcome, t_s: float, force_n: float) -> str:
    """The ``contacts.csv`` line of a contact (``repr`` of a Python float round-trips exactly);
    ``doubtful`` is 1 for a contact the GPIS took with a larger normal noise (issue 11)."""
    values = [*record.position_m, *record.normal, t_s, force_n, record.stand_yaw_rad, record.stand_tilt_rad]
    doubtful = int(bool(getattr(record.quality, "doubtful", False)))
    return f"{record.index}," + ",".join(repr(float(v)) for v in values) + f",{doubtful}\n"


def quality_fields(quality) -> dict:
    """The touch event's ``quality`` object: a :class:`explorer.contact.ContactQuality` as plain JSON
    values (None fields left out)."""
    out = {}
    for item in dataclasses.fields(quality):
        value = getattr(quality, item.name)
        if value is None:
            continue
        out[item.name] = [float(v) for v in value] if isinstance(value, tuple) else (
            bool(value) if isinstance(value, bool) else int(value) if isinstance(value, int) else float(value))
    return out


def read_contacts_csv(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Points (n, 3) and outward normals (n, 3) of a ``contacts.csv`` (object frame, metres)."""
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    if data.size == 0:
        return np.zeros((0, 3)), np.zeros((0, 3))
    if data.shape[1] < 7:
        raise ValueError(f"{path}: expected the columns {CONTACTS_HEADER.strip()}, got {data.shape[1]} per row")
    return data[:, 1:4], data[:, 4:7]
