"""Surface normal, force and contact point from the readings of one confirmed contact.

Once the spring has let the pad align with the surface, the sensor body's orientation gives the
surface normal: the pad's +z axis points out of the pad into the touched surface, so the outward
surface normal is minus that axis. The force comes from inverting the pad's pressure response, and
the contact point from the arm's forward kinematics (the spring pivot) plus the pivot-to-pad-face
offset rotated by the measured orientation.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from sensor.oriented_contact import OrientedContact
from sensor.reading import Reading
from sensor.sim.pad_response import PadResponse
from common.rotations import rotation_from_wxyz, wxyz_from_rotation

_IDENTITY_WXYZ = (1.0, 0.0, 0.0, 0.0)

#: Values of :attr:`SettlingConfig.window`.
WINDOW_CHOICES = ("first", "steadiest")


class OrientationNotSettledError(ValueError):
    """No window of the contact's readings had a steady enough orientation."""


@dataclass(frozen=True)
class SettlingConfig:
    """When the pad counts as aligned, and how much of it to average.

    Attributes
    ----------
    settle_window_s : float
        The orientation must stay steady for this long, seconds.
    max_deviation_rad : float
        Steady means every orientation in the window is within this angle of the window's mean,
        radians (default 1 degree; BNO055 white noise is ~0.07 degrees per axis).
    average_window_s : float
        The normal is averaged over the last ``average_window_s`` of the chosen steady window,
        seconds (<= settle_window_s).
    window : str
        Which steady window: ``"first"`` (the loop's hold stops there) or ``"steadiest"`` (the one
        whose largest deviation from its mean is smallest: a press read after the hold, whose pad
        may still have been turning when a loose test first passed).
    """

    settle_window_s: float = 0.1
    max_deviation_rad: float = math.radians(1.0)
    average_window_s: float = 0.05
    window: str = "first"

    def __post_init__(self) -> None:
        if self.window not in WINDOW_CHOICES:
            raise ValueError(f"window must be one of {', '.join(WINDOW_CHOICES)}, got {self.window!r}")
        if not self.settle_window_s > 0.0:
            raise ValueError(f"settle_window_s must be > 0 s, got {self.settle_window_s}")
        if not self.max_deviation_rad > 0.0:
            raise ValueError(f"max_deviation_rad must be > 0 rad, got {self.max_deviation_rad}")
        if not 0.0 <= self.average_window_s <= self.settle_window_s:
            raise ValueError(
                f"average_window_s must be in [0, settle_window_s={self.settle_window_s}] s, got {self.average_window_s}"
            )


@dataclass(frozen=True)
class ImuAlignment:
    """How the IMU's reported quaternion maps to the sensor body's orientation in the world.

    ``R_world_body = R(reference_in_world) @ R(q_reported) @ R(body_in_imu)``. Both are identity in
    simulation; hardware calibration sets them.

    Attributes
    ----------
    body_in_imu_wxyz : (4,) float
        Mounting offset: orientation of the sensor body frame in the IMU chip's frame.
    reference_in_world_wxyz : (4,) float
        Orientation of the IMU's fusion reference frame in the world frame.
    """

    body_in_imu_wxyz: tuple[float, float, float, float] = _IDENTITY_WXYZ
    reference_in_world_wxyz: tuple[float, float, float, float] = _IDENTITY_WXYZ

    def body_rotation(self, reported_wxyz) -> Rotation:
        """World-from-body rotation for a reported IMU quaternion."""
        return (rotation_from_wxyz(self.reference_in_world_wxyz) * rotation_from_wxyz(reported_wxyz)
                * rotation_from_wxyz(self.body_in_imu_wxyz))


@dataclass(frozen=True)
class NormalEstimate:
    """Normal and force of a settled contact.

    Attributes
    ----------
    t_s : float
        Time of the last reading of the averaging window, seconds.
    normal : (3,) float
        Outward unit surface normal, world frame.
    body_quat_wxyz : (4,) float
        Averaged sensor body orientation in the world frame (alignment applied).
    force_n : float
        Normal force from the mean pressure rise over the window, newtons.
    pressure_rise_pa : float
        Mean pressure above the baseline over the window, pascals.
    deviation_rad : float
        Largest angle between an orientation of the settled window and its mean, radians.
    """

    t_s: float
    normal: np.ndarray
    body_quat_wxyz: np.ndarray
    force_n: float
    pressure_rise_pa: float
    deviation_rad: float


def average_quaternion(quats_wxyz, weights=None) -> np.ndarray:
    """Mean orientation of unit quaternions, blind to their signs (q and -q are one orientation).

    The eigenvector of ``sum w q q^T`` with the largest eigenvalue (Markley et al., 2007), via scipy.

    Parameters
    ----------
    quats_wxyz : (n, 4) float
        Quaternions (w, x, y, z), n >= 1.
    weights : (n,) float, optional
        Non-negative weights.

    Returns
    -------
    (4,) float
        Mean unit quaternion with w >= 0.
    """
    quats = np.asarray(quats_wxyz, dtype=float)
    if quats.ndim != 2 or quats.shape[1] != 4 or len(quats) == 0:
        raise ValueError(f"quats_wxyz must have shape (n, 4) with n >= 1, got {quats.shape}")
    mean = wxyz_from_rotation(rotation_from_wxyz(quats).mean(weights=weights))
    return -mean if mean[0] < 0.0 else mean


def face_normal_world(body_rotation: Rotation) -> np.ndarray:
    """Outward surface normal (world frame) for a pad pressed flat on it: minus the body's +z axis."""
    return -body_rotation.apply([0.0, 0.0, 1.0])


def estimate_normal(
    readings: Sequence[Reading],
    baseline_pa: float,
    pad: PadResponse | None = None,
    settling: SettlingConfig | None = None,
    alignment: ImuAlignment | None = None,
) -> NormalEstimate:
    """Normal and force from the readings of one contact, once the orientation has settled.

    Parameters
    ----------
    readings : sequence of Reading
        Readings during the contact, in time order.
    baseline_pa : float
        Free-pad pressure (e.g. ``ContactEvent.baseline_pa`` of the start event), pascals.
    pad : PadResponse, optional
        Pad model inverted for the force (default: the simulation's defaults).
    settling : SettlingConfig, optional
        Steadiness criterion and averaging window.
    alignment : ImuAlignment, optional
        IMU mounting and reference-frame rotations (default identity).

    Raises
    ------
    OrientationNotSettledError
        If no ``settle_window_s`` span of the readings stays within ``max_deviation_rad``.
    """
    pad = pad if pad is not None else PadResponse()
    settling = settling if settling is not None else SettlingConfig()
    alignment = alignment if alignment is not None else ImuAlignment()
    if not math.isfinite(baseline_pa):
        raise ValueError(f"baseline_pa must be finite, got {baseline_pa}")
    readings = list(readings)
    times, quats = _times_and_quats(readings)
    start, stop, deviation = _settled_window(times, quats, settling)
    first_averaged = start + int(np.searchsorted(times[start:stop], times[stop - 1] - settling.average_window_s))
    window = slice(first_averaged, stop)
    mean_quat = average_quaternion(quats[window])
    body = alignment.body_rotation(mean_quat)
    rise = float(np.mean([r.pressure_pa for r in readings[window]])) - baseline_pa
    body_quat = wxyz_from_rotation(body)
    return NormalEstimate(
        t_s=float(times[stop - 1]),
        normal=face_normal_world(body),
        body_quat_wxyz=-body_quat if body_quat[0] < 0.0 else body_quat,
        force_n=pad.force_n(rise),
        pressure_rise_pa=rise,
        deviation_rad=deviation,
    )


def oriented_contact(
    readings: Sequence[Reading],
    pivot_position_m,
    pivot_to_pad_face_m,
    baseline_pa: float,
    pad: PadResponse | None = None,
    settling: SettlingConfig | None = None,
    alignment: ImuAlignment | None = None,
) -> OrientedContact:
    """The contact record: pad-face centre, outward normal, force, time and the readings used.

    ``position = pivot_position_m + R_world_body @ pivot_to_pad_face_m``, with R from the averaged,
    aligned IMU orientation.

    Parameters
    ----------
    readings : sequence of Reading
        Readings during the contact, in time order (all attached to the result).
    pivot_position_m : (3,) float
        Spring pivot position from the arm's forward kinematics, world frame, metres.
    pivot_to_pad_face_m : (3,) float
        Offset from the pivot to the centre of the pad face, sensor body frame, metres.
    baseline_pa, pad, settling, alignment
        As for :func:`estimate_normal`.
    """
    pivot = _vector3(pivot_position_m, "pivot_position_m")
    offset = _vector3(pivot_to_pad_face_m, "pivot_to_pad_face_m")
    estimate = estimate_normal(readings, baseline_pa, pad=pad, settling=settling, alignment=alignment)
    body = rotation_from_wxyz(estimate.body_quat_wxyz)
    return OrientedContact(
        t_s=estimate.t_s,
        position_m=pivot + body.apply(offset),
        normal=estimate.normal,
        force_n=estimate.force_n,
        readings=tuple(readings),
    )


def _vector3(value, name: str) -> np.ndarray:
    vector = np.asarray(value, dtype=float)
    if vector.shape != (3,) or not np.all(np.isfinite(vector)):
        raise ValueError(f"{name} must be 3 finite numbers, got {value!r}")
    return vector


def _times_and_quats(readings: Sequence[Reading]) -> tuple[np.ndarray, np.ndarray]:
    if len(readings) == 0:
        raise OrientationNotSettledError("no readings: cannot estimate a normal")
    times = np.array([r.t_s for r in readings], dtype=float)
    if np.any(np.diff(times) < 0.0):
        raise ValueError("readings must be in time order")
    quats = np.array([np.asarray(r.quat_wxyz, dtype=float) for r in readings])
    if quats.shape != (len(readings), 4) or not np.all(np.isfinite(quats)):
        raise ValueError("every reading needs a finite (4,) quat_wxyz")
    return times, quats


def _settled_window(times: np.ndarray, quats: np.ndarray,
                    settling: SettlingConfig) -> tuple[int, int, float]:
    """[start, stop) and deviation of the first (or the steadiest) span >= settle_window_s whose
    orientations all lie within ``max_deviation_rad`` of their mean."""
    best = None
    for stop in range(1, len(times) + 1):
        start = int(np.searchsorted(times, times[stop - 1] - settling.settle_window_s, side="right")) - 1
        if start < 0:
            continue
        window = quats[start:stop]
        mean = average_quaternion(window)
        cosines = np.clip(np.abs(window @ mean) / np.linalg.norm(window, axis=1), 0.0, 1.0)
        deviation = float(2.0 * np.arccos(cosines.min()))
        if deviation <= settling.max_deviation_rad:
            if settling.window == "first":
                return start, stop, deviation
            if best is None or deviation < best[2]:
                best = (start, stop, deviation)
    if best is not None:
        return best
    span = times[-1] - times[0]
    raise OrientationNotSettledError(
        f"orientation never settled: no {settling.settle_window_s * 1e3:.0f} ms window of the "
        f"{len(times)} readings ({span * 1e3:.0f} ms) stays within "
        f"{math.degrees(settling.max_deviation_rad):.2f} deg of its mean"
    )
