"""Live view of a fingertip sensor: pressure, drift-compensated pressure, contact state and orientation.

:class:`SensorMonitor` drains any :class:`~sensor.interface.TactileSensor`, runs the exploration's
:class:`~sensor.contact_detection.PressureContactDetector` on the readings and turns each into a
:class:`MonitorSample`; recorders (CSV file, session directory) receive every sample.
:func:`run_monitor` polls it for a while and prints one line per display period plus one per
contact event. ``scripts/sensor_monitor.py`` is the command line around it.
"""
from __future__ import annotations

import csv
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Protocol, TextIO

import numpy as np

from sensor.contact_detection import ContactEvent, PressureContactDetector, PressureDetectorConfig
from sensor.interface import TactileSensor
from sensor.normal_estimation import ImuAlignment, face_normal_world
from sensor.reading import Reading


@dataclass(frozen=True)
class MonitorSample:
    """One reading with what the monitor derived from it.

    Attributes
    ----------
    reading : Reading
    baseline_pa : float
        The detector's drift-tracking pressure baseline, pascals.
    rise_pa : float
        Drift-compensated pressure: pressure minus baseline, pascals.
    in_contact : bool
        Contact state after this reading.
    event : ContactEvent or None
        The contact start or end this reading confirmed.
    face_normal : (3,) float
        Outward surface normal a contact would give now: minus the sensor body's +z axis
        (alignment applied), world frame, unit.
    """

    reading: Reading
    baseline_pa: float
    rise_pa: float
    in_contact: bool
    event: ContactEvent | None
    face_normal: np.ndarray

    @property
    def tilt_deg(self) -> float:
        """Angle between ``face_normal`` and world up, degrees (0 when pressed flat on a level table)."""
        return math.degrees(math.acos(float(np.clip(self.face_normal[2], -1.0, 1.0))))


class Recorder(Protocol):
    """Receives every sample; closed when the monitor stops."""

    def write(self, sample: MonitorSample) -> None: ...

    def close(self) -> None: ...


class SensorMonitor:
    """Contact detection and orientation on a live reading stream.

    Parameters
    ----------
    sensor : TactileSensor
        Must be open while :meth:`poll` is called.
    detector : PressureDetectorConfig or None
        Contact thresholds (default: the exploration's).
    alignment : ImuAlignment or None
        IMU mounting (from a calibration file); identity by default.
    recorders : sequence of Recorder
    """

    def __init__(self, sensor: TactileSensor, detector: PressureDetectorConfig | None = None,
                 alignment: ImuAlignment | None = None, recorders=()):
        if not isinstance(sensor, TactileSensor):
            raise TypeError(f"sensor must be a TactileSensor, got {type(sensor).__name__}")
        self.sensor = sensor
        self.detector = PressureContactDetector(detector)
        self.alignment = alignment if alignment is not None else ImuAlignment()
        self.recorders = list(recorders)
        self.n_readings = 0
        self.n_contacts = 0

    def poll(self) -> list[MonitorSample]:
        """Process every reading since the previous poll; returns their samples, oldest first."""
        samples = [self.process(reading) for reading in self.sensor.drain()]
        for sample in samples:
            for recorder in self.recorders:
                recorder.write(sample)
        return samples

    def process(self, reading: Reading) -> MonitorSample:
        """Feed one reading (time order) to the detector; its sample (recorders are not called)."""
        event = self.detector.update(reading)
        baseline = float(self.detector.baseline_pa)
        self.n_readings += 1
        if event is not None and event.kind == "start":
            self.n_contacts += 1
        normal = face_normal_world(self.alignment.body_rotation(reading.quat_wxyz))
        return MonitorSample(reading, baseline, reading.pressure_pa - baseline, self.detector.in_contact, event,
                             normal)


def format_sample(sample: MonitorSample, t0_s: float = 0.0) -> str:
    """One terminal line: time since ``t0_s``, pressure, compensated pressure, contact, quaternion, normal, tilt."""
    r = sample.reading
    w, x, y, z = np.asarray(r.quat_wxyz, dtype=float) + 0.0
    n = sample.face_normal + 0.0  # no "-0.000"
    state = "CONTACT" if sample.in_contact else "free   "
    return (f"t {r.t_s - t0_s:8.3f} s  p {r.pressure_pa:10.1f} Pa  dp {sample.rise_pa:+8.1f} Pa  {state}  "
            f"q ({w:+.4f} {x:+.4f} {y:+.4f} {z:+.4f})  n ({n[0]:+.3f} {n[1]:+.3f} {n[2]:+.3f})  "
            f"tilt {sample.tilt_deg:5.1f} deg")


def format_event(sample: MonitorSample, t0_s: float = 0.0) -> str:
    """One line for the contact start or end ``sample`` confirmed, times since ``t0_s``."""
    event = sample.event
    return (f"** contact {event.kind} at {event.t_s - t0_s:.3f} s (onset {event.onset_t_s - t0_s:.3f} s): "
            f"{event.signal:+.1f} Pa above baseline {event.baseline_pa:.1f} Pa")


CSV_COLUMNS = ("t_s", "pressure_pa", "baseline_pa", "rise_pa", "in_contact", "qw", "qx", "qy", "qz",
               "normal_x", "normal_y", "normal_z", "temperature_c")


class CsvRecorder:
    """Writes every sample as a CSV row (columns ``CSV_COLUMNS``, floats as ``repr``)."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        if self.path.exists():
            raise FileExistsError(f"{self.path} exists; choose a new CSV file name")
        self._file = self.path.open("w", newline="")
        self._writer = csv.writer(self._file)
        self._writer.writerow(CSV_COLUMNS)

    def write(self, sample: MonitorSample) -> None:
        r = sample.reading
        self._writer.writerow([repr(float(v)) for v in (
            r.t_s, r.pressure_pa, sample.baseline_pa, sample.rise_pa, float(sample.in_contact),
            *np.asarray(r.quat_wxyz, dtype=float), *sample.face_normal, r.temperature_c)])

    def close(self) -> None:
        self._file.close()


class SessionRecorder:
    """Appends every reading, and contact starts/ends as events, to a :class:`explorer.session.SessionWriter`."""

    def __init__(self, directory: str | Path, sensor_description: str):
        from explorer.session import SessionWriter
        self.writer = SessionWriter(directory, {"robot": None, "sensor": sensor_description, "object": None,
                                                "seed": None, "configuration": {"program": "sensor-monitor"}})

    def write(self, sample: MonitorSample) -> None:
        self.writer.write_reading(sample.reading)
        if sample.event is not None:
            self.writer.write_event(f"contact_{sample.event.kind}", sample.event.t_s,
                                    signal_pa=sample.event.signal, baseline_pa=sample.event.baseline_pa)

    def close(self) -> None:
        self.writer.close()


@dataclass(frozen=True)
class MonitorSummary:
    """What a monitoring run saw: readings, contacts, and the time it ran (sensor clock), seconds."""

    n_readings: int
    n_contacts: int
    duration_s: float


def run_monitor(monitor: SensorMonitor, duration_s: float, *, display_hz: float = 10.0, poll_hz: float = 100.0,
                out: TextIO | None = None, clock: Callable[[], float] = time.monotonic,
                sleep: Callable[[float], None] = time.sleep) -> MonitorSummary:
    """Poll ``monitor`` for ``duration_s`` seconds (``math.inf``: until Ctrl-C), printing to ``out`` (None: silent).

    Prints the newest sample every ``1 / display_hz`` seconds and every contact event at once, with
    times counted from the first reading.
    Recorders are closed at the end (also after an error or Ctrl-C).
    """
    if not duration_s > 0.0:  # math.inf: until interrupted
        raise ValueError(f"duration_s must be a positive number of seconds, got {duration_s}")
    if not display_hz > 0.0 or not poll_hz > 0.0:
        raise ValueError(f"display_hz and poll_hz must be > 0, got {display_hz}, {poll_hz}")
    start = clock()
    next_display = start
    t0 = None
    try:
        while clock() - start < duration_s:
            samples = monitor.poll()
            if out is not None and samples:
                t0 = samples[0].reading.t_s if t0 is None else t0
                for sample in samples:
                    if sample.event is not None:
                        print(format_event(sample, t0), file=out)
                if clock() >= next_display:
                    print(format_sample(samples[-1], t0), file=out)
                    next_display = clock() + 1.0 / display_hz
            sleep(1.0 / poll_hz)
    finally:
        for recorder in monitor.recorders:
            recorder.close()
    return MonitorSummary(monitor.n_readings, monitor.n_contacts, clock() - start)
