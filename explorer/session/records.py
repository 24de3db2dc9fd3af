"""What a session holds once read back: plain dataclasses of numpy arrays and JSON values."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any, Iterator, Mapping

import numpy as np

from explorer.session.layout import READINGS_COLUMNS
from sensor.oriented_contact import OrientedContact
from sensor.reading import Reading


def _read_only(array: np.ndarray) -> np.ndarray:
    array = np.array(array, dtype=np.float64)
    array.setflags(write=False)
    return array


@dataclass(frozen=True, eq=False)
class Readings:
    """The raw sensor stream, one row per :class:`~sensor.reading.Reading`, oldest first.

    Attributes
    ----------
    t_s : (n,) float
        Time stamps, seconds, non-decreasing.
    pressure_pa : (n,) float
        Barometer pressure, pascals.
    quat_wxyz : (n, 4) float
        Sensor orientation, world frame, unit quaternion (w, x, y, z).
    lin_acc_mps2 : (n, 3) float
        Linear acceleration without gravity, sensor frame, m/s^2.
    gravity_mps2 : (n, 3) float
        Gravity vector, sensor frame, m/s^2.
    temperature_c : (n,) float
        Barometer temperature, degrees Celsius.
    """

    t_s: np.ndarray
    pressure_pa: np.ndarray
    quat_wxyz: np.ndarray
    lin_acc_mps2: np.ndarray
    gravity_mps2: np.ndarray
    temperature_c: np.ndarray

    @classmethod
    def from_rows(cls, rows: np.ndarray) -> "Readings":
        """Build from the ``(n, 13)`` table of ``readings.csv`` (columns in file order)."""
        rows = np.asarray(rows, dtype=np.float64).reshape(-1, len(READINGS_COLUMNS))
        return cls(
            t_s=_read_only(rows[:, 0]),
            pressure_pa=_read_only(rows[:, 1]),
            quat_wxyz=_read_only(rows[:, 2:6]),
            lin_acc_mps2=_read_only(rows[:, 6:9]),
            gravity_mps2=_read_only(rows[:, 9:12]),
            temperature_c=_read_only(rows[:, 12]),
        )

    def __len__(self) -> int:
        return len(self.t_s)

    def __getitem__(self, index: int) -> Reading:
        """The ``index``-th reading as a :class:`~sensor.reading.Reading`."""
        return Reading(
            t_s=float(self.t_s[index]),
            pressure_pa=float(self.pressure_pa[index]),
            quat_wxyz=self.quat_wxyz[index].copy(),
            lin_acc_mps2=self.lin_acc_mps2[index].copy(),
            gravity_mps2=self.gravity_mps2[index].copy(),
            temperature_c=float(self.temperature_c[index]),
        )

    def __iter__(self) -> Iterator[Reading]:
        return (self[i] for i in range(len(self)))


@dataclass(frozen=True, eq=False)
class JointStates:
    """Joint positions as the encoders reported them, oldest first.

    Attributes
    ----------
    t_s : (k,) float
        Time stamps, seconds, non-decreasing.
    q : (k, dof) float
        Joint positions, radians (metres for prismatic joints).
    """

    t_s: np.ndarray
    q: np.ndarray

    @classmethod
    def from_rows(cls, rows: np.ndarray, dof: int) -> "JointStates":
        """Build from the ``(k, 1 + dof)`` table of ``joint_states.csv``."""
        rows = np.asarray(rows, dtype=np.float64).reshape(-1, 1 + dof)
        return cls(t_s=_read_only(rows[:, 0]), q=_read_only(rows[:, 1:]))

    @property
    def dof(self) -> int:
        """Number of joints (0 when the session holds no joint state)."""
        return self.q.shape[1]

    def __len__(self) -> int:
        return len(self.t_s)


@dataclass(frozen=True)
class Event:
    """Something that happened during the run (contact start/end, touch, miss, error, ...).

    Attributes
    ----------
    kind : str
        Event kind, lower-case identifier; see ``docs/SESSION_FORMAT.md`` for the standard kinds.
    t_s : float
        Time, seconds, on the same clock as the readings.
    fields : Mapping[str, Any]
        The event's own fields as JSON values (vectors come back as lists of floats).
    """

    kind: str
    t_s: float
    fields: Mapping[str, Any]

    def __post_init__(self):
        object.__setattr__(self, "fields", MappingProxyType(dict(self.fields)))


@dataclass(frozen=True)
class ReconstructionSnapshot:
    """A surface reconstruction saved during the run.

    Attributes
    ----------
    t_s : float
        Time the snapshot was taken, seconds.
    n_contacts : int
        Number of contacts the reconstruction was fitted to.
    path : Path
        The PLY mesh file (binary little-endian, float64 vertices, object frame = world frame, metres).
    n_vertices, n_faces : int
        Size of the mesh.
    """

    t_s: float
    n_contacts: int
    path: Path
    n_vertices: int
    n_faces: int


@dataclass(frozen=True, eq=False)
class Session:
    """Everything a session directory holds, up to its last complete record.

    Attributes
    ----------
    directory : Path
        The session directory.
    metadata : dict
        Contents of ``metadata.json`` (run description plus format fields).
    readings : Readings
        Raw sensor stream.
    joint_states : JointStates
        Joint positions over time.
    contacts : tuple of OrientedContact
        Detected contacts; each one's ``readings`` are taken from the raw stream.
    events : tuple of Event
        Events in the order they were written.
    reconstructions : tuple of ReconstructionSnapshot
        Reconstruction snapshots in the order they were written.
    truncated_files : tuple of str
        Names of the files that ended in an incomplete record (a crash mid-write); that record
        is not in the data above. Empty for a cleanly written session.
    """

    directory: Path
    metadata: dict
    readings: Readings
    joint_states: JointStates
    contacts: tuple[OrientedContact, ...]
    events: tuple[Event, ...]
    reconstructions: tuple[ReconstructionSnapshot, ...]
    truncated_files: tuple[str, ...]

    @property
    def closed_cleanly(self) -> bool:
        """True when the writer was closed without an exception (not killed, not aborted)."""
        return self.metadata.get("end_status") == "closed"
