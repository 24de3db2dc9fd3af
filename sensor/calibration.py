"""Fingertip calibration: pressure baseline from a quiet period, IMU mounting offset from presses on a level table.

Mounting offset. The normal estimate uses ``R_world_body = R(reference_in_world) R(q_reported)
R(body_in_imu)`` (:class:`sensor.normal_estimation.ImuAlignment`). Pressed flat on a level table,
the body's +z axis points straight down, so in the IMU frame it is

    d_i = R(q_i)^T R(reference_in_world)^T (0, 0, -1)

for every press i, whatever the arm's yaw. The mean of the ``d_i`` is the body z axis in the
IMU frame; the smallest rotation taking the IMU's z axis onto it is the mounting offset returned.
The rotation about the face normal cannot be seen from a level table and is set to zero: it
does not change the estimated normals, only the heading of the body frame.

The result is saved with the pressure baseline (and optionally a BNO055 calibration profile) in
a JSON file that a backend configuration refers to (``[sensor] calibration = "..."``).
"""
from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from sensor.contact_detection import PressureContactDetector, PressureDetectorConfig
from sensor.normal_estimation import ImuAlignment, OrientationNotSettledError, SettlingConfig, estimate_normal
from sensor.pad_calibration import PadCalibration
from sensor.reading import Reading
from common.rotations import rotation_from_wxyz, wxyz_from_rotation

FILE_FORMAT = "tactile-sensor-calibration"
FILE_VERSION = 1
IDENTITY_WXYZ = (1.0, 0.0, 0.0, 0.0)
MIN_BASELINE_READINGS = 20
MAX_PRESS_SPREAD_RAD = math.radians(3.0)
#: Stricter than the exploration's default: calibration presses are held still on purpose.
CALIBRATION_SETTLING = SettlingConfig(settle_window_s=0.15, max_deviation_rad=math.radians(0.5),
                                      average_window_s=0.1)


@dataclass(frozen=True)
class PressureBaseline:
    """Free-pad pressure over a quiet period.

    Attributes
    ----------
    mean_pa : float
        Mean pressure, pascals.
    noise_std_pa : float
        Standard deviation about a straight-line fit (drift removed), pascals.
    drift_pa_per_s : float
        Slope of that fit, Pa/s.
    n_readings : int
    duration_s : float
    """

    mean_pa: float
    noise_std_pa: float
    drift_pa_per_s: float
    n_readings: int
    duration_s: float


def measure_pressure_baseline(readings: Sequence[Reading], min_readings: int = MIN_BASELINE_READINGS
                              ) -> PressureBaseline:
    """Mean, noise and drift of the pressure over a quiet period (pad free and still).

    Raises
    ------
    ValueError
        Fewer than ``min_readings`` readings, times not increasing, non-finite pressures.
    """
    readings = list(readings)
    if len(readings) < max(3, min_readings):
        raise ValueError(f"a pressure baseline needs at least {max(3, min_readings)} readings, got {len(readings)}")
    t = np.array([r.t_s for r in readings], dtype=float)
    p = np.array([r.pressure_pa for r in readings], dtype=float)
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(p))):
        raise ValueError("baseline readings contain non-finite times or pressures")
    if np.any(np.diff(t) <= 0.0):
        raise ValueError("baseline readings must have strictly increasing times")
    centred = t - t.mean()
    slope = float(centred @ (p - p.mean()) / (centred @ centred))
    residual = p - p.mean() - slope * centred
    noise = float(np.sqrt(residual @ residual / (len(p) - 2)))
    return PressureBaseline(mean_pa=float(p.mean()), noise_std_pa=noise, drift_pa_per_s=slope,
                            n_readings=len(p), duration_s=float(t[-1] - t[0]))


@dataclass(frozen=True)
class Presses:
    """Settled orientations of the presses found in a reading stream.

    Attributes
    ----------
    quats_wxyz : (n, 4) float
        Mean reported IMU quaternion over each press's settled window.
    t_s : (n,) float
        Time of each press's settled window end, seconds.
    skipped : tuple of str
        Why each press that was not used was skipped (never settled, still pressed at the end).
    """

    quats_wxyz: np.ndarray
    t_s: np.ndarray
    skipped: tuple[str, ...]


def find_presses(readings: Sequence[Reading], detector: PressureDetectorConfig | None = None,
                 settling: SettlingConfig = CALIBRATION_SETTLING) -> Presses:
    """Split ``readings`` (time order, pad free at the start) into presses and average each settled orientation."""
    readings = list(readings)
    contact_detector = PressureContactDetector(detector)
    quats, times, skipped = [], [], []
    current: list[Reading] | None = None
    baseline = math.nan
    for reading in readings:
        event = contact_detector.update(reading)
        if event is not None and event.kind == "start":
            current, baseline = [], float(event.baseline_pa)
        if current is not None:
            current.append(reading)
        if event is not None and event.kind == "end":
            _settle(current, baseline, settling, quats, times, skipped)
            current = None
    if current is not None:
        skipped.append(f"press starting at {current[0].t_s:.3f} s had not ended when the readings stopped")
    return Presses(np.array(quats).reshape(-1, 4), np.array(times), tuple(skipped))


def _settle(readings: list[Reading], baseline: float, settling: SettlingConfig, quats: list, times: list,
            skipped: list) -> None:
    try:
        estimate = estimate_normal(readings, baseline, settling=settling)
    except OrientationNotSettledError as error:
        skipped.append(f"press at {readings[0].t_s:.3f} s: {error}")
        return
    quats.append(estimate.body_quat_wxyz)  # identity alignment: the mean reported quaternion
    times.append(estimate.t_s)


@dataclass(frozen=True)
class MountingEstimate:
    """The IMU mounting offset found from presses on a level table.

    Attributes
    ----------
    body_in_imu_wxyz : (4,) float
        Orientation of the sensor body frame in the IMU frame (for :class:`ImuAlignment`);
        the smallest rotation taking the IMU z axis onto ``face_axis_in_imu``.
    face_axis_in_imu : (3,) float
        The body's +z axis (pointing out of the pad face) in the IMU frame, unit.
    tilt_rad : float
        Angle between the IMU z axis and the body z axis, radians.
    spread_rad : float
        Largest angle between one press's body axis and the mean, radians.
    n_presses : int
    """

    body_in_imu_wxyz: np.ndarray
    face_axis_in_imu: np.ndarray
    tilt_rad: float
    spread_rad: float
    n_presses: int


def estimate_imu_mounting(press_quats_wxyz, reference_in_world_wxyz=IDENTITY_WXYZ,
                          max_spread_rad: float = MAX_PRESS_SPREAD_RAD) -> MountingEstimate:
    """Mounting offset from the reported IMU quaternions of presses flat on a level table.

    Parameters
    ----------
    press_quats_wxyz : (n, 4) float
        One settled, reported quaternion per press, n >= 1 (3 or more recommended).
    reference_in_world_wxyz : (4,) float
        The IMU fusion frame in the world (identity when the fusion frame is gravity-aligned, as
        the BNO055's is).
    max_spread_rad : float
        Presses whose body axes disagree by more than this raise ValueError (table not level,
        pad not flat, the IMU slipping).
    """
    quats = np.asarray(press_quats_wxyz, dtype=float)
    if quats.ndim != 2 or quats.shape[1] != 4 or len(quats) == 0 or not np.all(np.isfinite(quats)):
        raise ValueError(f"press_quats_wxyz must be a finite (n, 4) array with n >= 1, got shape {quats.shape}")
    if np.any(np.abs(np.linalg.norm(quats, axis=1) - 1.0) > 0.01):
        raise ValueError("press_quats_wxyz must hold unit quaternions (w, x, y, z)")
    world_from_imu = rotation_from_wxyz(reference_in_world_wxyz) * rotation_from_wxyz(quats)
    down_in_imu = world_from_imu.inv().apply([0.0, 0.0, -1.0])
    axis = down_in_imu.mean(axis=0)
    axis /= np.linalg.norm(axis)
    spread = float(np.max(np.arctan2(np.linalg.norm(np.cross(down_in_imu, axis), axis=1), down_in_imu @ axis)))
    if spread > max_spread_rad:
        raise ValueError(
            f"the {len(quats)} presses disagree: one body axis is {math.degrees(spread):.2f} deg from their mean "
            f"(allowed {math.degrees(max_spread_rad):.2f} deg); is the table level and was the pad pressed flat?")
    mounting = _smallest_rotation([0.0, 0.0, 1.0], axis)
    quat = wxyz_from_rotation(mounting)
    quat = -quat if quat[0] < 0.0 else quat
    tilt = float(np.arctan2(np.linalg.norm(axis[:2]), axis[2]))
    return MountingEstimate(quat, axis, tilt, spread, len(quats))


def _smallest_rotation(a, b) -> Rotation:
    """The rotation of smallest angle taking unit vector ``a`` onto unit vector ``b``."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    cross, cosine = np.cross(a, b), float(np.clip(a @ b, -1.0, 1.0))
    norm = float(np.linalg.norm(cross))
    if norm < 1e-12:
        if cosine > 0.0:
            return Rotation.identity()
        perpendicular = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        return Rotation.from_rotvec(math.pi * perpendicular / np.linalg.norm(perpendicular))
    return Rotation.from_rotvec(cross / norm * math.atan2(norm, cosine))


@dataclass(frozen=True)
class SensorCalibration:
    """What the calibration file holds.

    Attributes
    ----------
    pressure_baseline : PressureBaseline or None
    mounting : MountingEstimate or None
    reference_in_world_wxyz : (4,) float
        IMU fusion frame in the world (identity by default; see :class:`ImuAlignment`).
    bno055_profile_hex : str or None
        BNO055 offsets to restore after power-up (``CalibrationProfile.to_hex()``).
    created_utc : str
    """

    pressure_baseline: PressureBaseline | None = None
    mounting: MountingEstimate | None = None
    reference_in_world_wxyz: tuple[float, float, float, float] = IDENTITY_WXYZ
    bno055_profile_hex: str | None = None
    created_utc: str = ""

    def imu_alignment(self) -> ImuAlignment:
        """The :class:`ImuAlignment` for normal estimation (identity mounting if none was measured)."""
        body = IDENTITY_WXYZ if self.mounting is None else tuple(float(v) for v in self.mounting.body_in_imu_wxyz)
        return ImuAlignment(body_in_imu_wxyz=body,
                            reference_in_world_wxyz=tuple(float(v) for v in self.reference_in_world_wxyz))

    def pad_calibration(self) -> PadCalibration:
        """The :class:`sensor.pad_calibration.PadCalibration` of this sensor: the measured IMU
        mounting, with the nominal pad force model and compliance (the file does not measure those)."""
        return PadCalibration(alignment=self.imu_alignment())

    def to_dict(self) -> dict:
        baseline = self.pressure_baseline
        mounting = self.mounting
        return {
            "format": FILE_FORMAT,
            "version": FILE_VERSION,
            "created_utc": self.created_utc or datetime.now(timezone.utc).isoformat(timespec="seconds"),
            "pressure_baseline": None if baseline is None else {
                "mean_pa": baseline.mean_pa, "noise_std_pa": baseline.noise_std_pa,
                "drift_pa_per_s": baseline.drift_pa_per_s, "n_readings": baseline.n_readings,
                "duration_s": baseline.duration_s},
            "imu_alignment": {
                "body_in_imu_wxyz": list(self.imu_alignment().body_in_imu_wxyz),
                "reference_in_world_wxyz": [float(v) for v in self.reference_in_world_wxyz],
                "face_axis_in_imu": None if mounting is None else [float(v) for v in mounting.face_axis_in_imu],
                "tilt_deg": None if mounting is None else math.degrees(mounting.tilt_rad),
                "spread_deg": None if mounting is None else math.degrees(mounting.spread_rad),
                "n_presses": None if mounting is None else mounting.n_presses,
            },
            "bno055_profile_hex": self.bno055_profile_hex,
        }

    def save(self, path: str | Path) -> Path:
        """Write the JSON file (replacing it atomically); returns the path."""
        path = Path(path)
        temporary = path.with_name(path.name + ".tmp")
        temporary.write_text(json.dumps(self.to_dict(), indent=2) + "\n")
        temporary.replace(path)
        return path

    @classmethod
    def load(cls, path: str | Path) -> "SensorCalibration":
        """Read a file written by :meth:`save`; errors name the file and the bad field."""
        path = Path(path)
        try:
            data = json.loads(path.read_text())
        except FileNotFoundError:
            raise FileNotFoundError(f"calibration file not found: {path}") from None
        except json.JSONDecodeError as error:
            raise ValueError(f"calibration file {path} is not valid JSON: {error}") from None
        if not isinstance(data, dict) or data.get("format") != FILE_FORMAT:
            raise ValueError(f"{path} is not a sensor calibration file (no \"format\": \"{FILE_FORMAT}\")")
        if data.get("version") != FILE_VERSION:
            raise ValueError(f"{path}: calibration file version {data.get('version')!r} is not supported "
                             f"(this code reads version {FILE_VERSION})")
        try:
            return cls._from_dict(data)
        except (KeyError, TypeError, ValueError) as error:
            raise ValueError(f"calibration file {path}: {error}") from None

    @classmethod
    def _from_dict(cls, data: dict) -> "SensorCalibration":
        baseline = data.get("pressure_baseline")
        if baseline is not None:
            baseline = PressureBaseline(float(baseline["mean_pa"]), float(baseline["noise_std_pa"]),
                                        float(baseline["drift_pa_per_s"]), int(baseline["n_readings"]),
                                        float(baseline["duration_s"]))
        alignment = data["imu_alignment"]
        body = _unit_quat(alignment["body_in_imu_wxyz"], "imu_alignment.body_in_imu_wxyz")
        reference = _unit_quat(alignment["reference_in_world_wxyz"], "imu_alignment.reference_in_world_wxyz")
        mounting = None
        if alignment.get("face_axis_in_imu") is not None:
            mounting = MountingEstimate(body, np.asarray(alignment["face_axis_in_imu"], dtype=float),
                                        math.radians(float(alignment["tilt_deg"])),
                                        math.radians(float(alignment["spread_deg"])), int(alignment["n_presses"]))
        elif not np.allclose(body, IDENTITY_WXYZ):  # written by hand: only the quaternion
            axis = rotation_from_wxyz(body).apply([0.0, 0.0, 1.0])
            mounting = MountingEstimate(body, axis, float(np.arccos(np.clip(axis[2], -1.0, 1.0))), 0.0, 0)
        profile = data.get("bno055_profile_hex")
        if profile is not None and not isinstance(profile, str):
            raise ValueError(f"bno055_profile_hex must be a string or null, got {profile!r}")
        return cls(baseline, mounting, tuple(float(v) for v in reference), profile, str(data.get("created_utc", "")))


def _unit_quat(values, name: str) -> np.ndarray:
    quat = np.asarray(values, dtype=float)
    if quat.shape != (4,) or not np.all(np.isfinite(quat)) or abs(np.linalg.norm(quat) - 1.0) > 1e-6:
        raise ValueError(f"{name} must be a unit quaternion [w, x, y, z], got {values!r}")
    return quat


def calibrate(quiet_readings: Sequence[Reading], press_readings: Sequence[Reading],
              reference_in_world_wxyz=IDENTITY_WXYZ, min_presses: int = 3,
              detector: PressureDetectorConfig | None = None) -> tuple[SensorCalibration, Presses]:
    """The whole routine: baseline from ``quiet_readings``, mounting from the presses in ``press_readings``.

    Returns the calibration and the presses found (with the reasons for any skipped).

    Raises
    ------
    ValueError
        Fewer than ``min_presses`` usable presses, or the checks of
        :func:`measure_pressure_baseline` and :func:`estimate_imu_mounting`.
    """
    baseline = measure_pressure_baseline(quiet_readings)
    presses = find_presses(press_readings, detector)
    if len(presses.quats_wxyz) < min_presses:
        reasons = "; ".join(presses.skipped) or "no contact detected"
        raise ValueError(f"found {len(presses.quats_wxyz)} usable presses, need {min_presses} ({reasons})")
    mounting = estimate_imu_mounting(presses.quats_wxyz, reference_in_world_wxyz)
    calibration = SensorCalibration(pressure_baseline=baseline, mounting=mounting,
                                    reference_in_world_wxyz=tuple(float(v) for v in reference_in_world_wxyz))
    return calibration, presses



def record_calibration(sensor, *, quiet_s: float = 2.0, n_presses: int = 5, timeout_s: float = 60.0,
                       poll_hz: float = 100.0, out=None, clock=time.monotonic, sleep=time.sleep,
                       detector: PressureDetectorConfig | None = None) -> tuple[SensorCalibration, Presses]:
    """Run the calibration on a live, open sensor: a quiet period, then presses on a level table.

    Prints instructions to ``out`` (None: silent). Collects ``quiet_s`` seconds of readings with
    the pad free and still, then readings until ``n_presses`` contacts have ended (or
    ``timeout_s`` has passed), and returns :func:`calibrate`'s result (at least
    ``min(n_presses, 3)`` presses must have settled).

    Raises
    ------
    ValueError
        Too few presses within ``timeout_s``, or the checks of :func:`calibrate`.
    """
    if not quiet_s > 0.0 or not timeout_s > 0.0 or n_presses < 1 or not poll_hz > 0.0:
        raise ValueError(f"need quiet_s > 0, timeout_s > 0, poll_hz > 0 and n_presses >= 1, got {quiet_s}, "
                         f"{timeout_s}, {poll_hz}, {n_presses}")

    def say(text: str) -> None:
        if out is not None:
            print(text, file=out, flush=True)

    say(f"calibration 1/2: keep the pad free and still for {quiet_s:.1f} s ...")
    sensor.drain()  # only what comes from now on
    start = clock()
    quiet = _collect(sensor, lambda: clock() - start >= quiet_s, poll_hz, sleep, None)
    baseline = measure_pressure_baseline(quiet)
    say(f"  pressure {baseline.mean_pa:.1f} Pa, noise {baseline.noise_std_pa:.2f} Pa RMS, "
        f"drift {baseline.drift_pa_per_s:+.2f} Pa/s ({baseline.n_readings} readings)")
    say(f"calibration 2/2: press the pad flat on a level table {n_presses} times, about half a second each, "
        f"turning the fingertip between presses ...")
    counter = PressureContactDetector(detector)
    ended = []

    def count(reading: Reading) -> None:
        event = counter.update(reading)
        if event is not None and event.kind == "end":
            ended.append(event)
            say(f"  press {len(ended)}/{n_presses}")

    start = clock()
    presses = _collect(sensor, lambda: len(ended) >= n_presses or clock() - start >= timeout_s, poll_hz, sleep,
                       count)
    if len(ended) < n_presses:
        raise ValueError(f"only {len(ended)} of {n_presses} presses within {timeout_s:.0f} s")
    calibration, found = calibrate(quiet, presses, min_presses=min(n_presses, 3), detector=detector)
    for reason in found.skipped:
        say(f"  skipped: {reason}")
    return calibration, found


def _collect(sensor, done, poll_hz: float, sleep, on_reading) -> list[Reading]:
    readings: list[Reading] = []
    while not done():
        sleep(1.0 / poll_hz)
        for reading in sensor.drain():
            readings.append(reading)
            if on_reading is not None:
                on_reading(reading)
    return readings
