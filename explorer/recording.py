"""Writing a run as it happens: the session record and ``contacts.csv``.

Every contact is appended (and fsynced) to ``contacts.csv`` in the object frame the moment it is
recorded, and the raw stream goes to the session directory (:mod:`explorer.session`), so a run
killed halfway keeps every contact it made.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from explorer.loop import Recorder, TouchRecord
from explorer.session import SessionWriter

CONTACTS_HEADER = "touch,x,y,z,nx,ny,nz,t_s,force_n,stand_yaw_rad,stand_tilt_rad\n"


class RunRecorder(Recorder):
    """Records a run into ``out_dir``: ``session/`` and ``contacts.csv``.

    Parameters
    ----------
    out_dir : Path
    metadata : dict
        Session metadata (robot, sensor, object, seed, configuration).
    resume : bool
        Append to an existing run instead of refusing to overwrite it.
    """

    def __init__(self, out_dir: Path, metadata: dict, resume: bool = False):
        self.out_dir = Path(out_dir)
        self.out_dir.mkdir(parents=True, exist_ok=True)
        self.session = SessionWriter(self.out_dir / "session", metadata, resume=resume)
        path = self.out_dir / "contacts.csv"
        fresh = not path.exists() or not resume
        self._contacts = open(path, "w" if fresh else "a", encoding="utf-8")
        if fresh:
            self._contacts.write(CONTACTS_HEADER)
            self._flush()

    def readings(self, readings) -> None:
        for reading in readings:
            self.session.write_reading(reading)

    def joint_state(self, t_s: float, q: np.ndarray) -> None:
        self.session.write_joint_state(t_s, q)

    def touch(self, record: TouchRecord) -> None:
        kind = "touch" if record.kind == "contact" else ("miss" if record.kind == "miss" else record.kind)
        fields = dict(target_m=record.target_m.tolist(), approach_dir=record.approach_dir.tolist(),
                      index=record.index, result=record.kind,
                      stand_yaw_rad=record.stand_yaw_rad, stand_tilt_rad=record.stand_tilt_rad)
        if record.press_t_s is not None:
            fields["press_t_s"] = list(record.press_t_s)
        if record.position_m is not None:  # also for contacts set aside for a realign touch
            fields.update(position_m=record.position_m.tolist(), normal=record.normal.tolist())
        self.session.write_event(kind, record.t_s, **fields)
        if record.kind != "contact":
            return
        self.session.write_contact(record.contact)
        values = [*record.position_m, *record.normal, record.contact.t_s, record.contact.force_n,
                  record.stand_yaw_rad, record.stand_tilt_rad]
        # repr of a Python float round-trips exactly
        self._contacts.write(f"{record.index}," + ",".join(repr(float(v)) for v in values) + "\n")
        self._flush()

    def event(self, kind: str, t_s: float, **fields) -> None:
        self.session.write_event(kind, t_s, **fields)

    def reconstruction(self, mesh, n_contacts: int, t_s: float) -> None:
        self.session.write_reconstruction(mesh, n_contacts, t_s)

    def close(self, error: BaseException | None = None) -> None:
        if not self._contacts.closed:
            self._contacts.close()
        if not self.session.closed:
            self.session.close(error=error)

    def _flush(self) -> None:
        self._contacts.flush()
        os.fsync(self._contacts.fileno())


def read_contacts_csv(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Points (n, 3) and outward normals (n, 3) of a ``contacts.csv`` (object frame, metres)."""
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    if data.size == 0:
        return np.zeros((0, 3)), np.zeros((0, 3))
    return data[:, 1:4], data[:, 4:7]
