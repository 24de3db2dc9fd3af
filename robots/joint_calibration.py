"""Joint-offset calibration by touching a known sphere, and a robot that applies the result.

A lab calibrates its arm's encoder offsets the way the fingertip measures anything: it touches a
sphere of known centre and radius (a calibration ball on the table, measured once) at poses spread
over the arm's workspace. Each touch gives the encoder readings ``q_i`` and the sensor body's
orientation ``R_i`` from the IMU; the pad face centre the loop computes is
``p_i(o) = FK_pivot(q_i - o) + R_i a`` (``a``: pivot to pad, body frame) and must lie on the sphere.
The offsets ``o`` (encoder reading minus true angle) solve the nonlinear least squares

    min_o  sum_i (|p_i(o) - c| - r)^2   (+ a small ridge on o for unobservable directions)

(scipy's trust-region reflective solver). One residual per touch: use at least three touches per
offset and poses that turn every joint, or some combinations stay unobservable (the ridge then
keeps them at zero; ``FitResult.singular_values`` shows it).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from robots.interface import GuardedMoveResult, Robot


@dataclass(frozen=True)
class SphereTouches:
    """Touches of a known sphere (world frame, metres).

    Attributes
    ----------
    q_rad : (n, dof) float
        Encoder readings at each settled touch, radians.
    body_quat_wxyz : (n, 4) float
        Sensor body orientation at each touch (IMU, aligned), world frame.
    centre_m : (3,) or (n, 3) float
        The sphere's centre, or each touch's sphere centre (several balls, or one ball moved
        between known places: more diverse poses).
    radius_m : float
    """

    q_rad: np.ndarray
    body_quat_wxyz: np.ndarray
    centre_m: np.ndarray
    radius_m: float

    def __post_init__(self) -> None:
        q = np.asarray(self.q_rad, float)
        quats = np.asarray(self.body_quat_wxyz, float)
        if q.ndim != 2 or quats.shape != (len(q), 4):
            raise ValueError(f"q_rad must be (n, dof) and body_quat_wxyz (n, 4), got {q.shape}, {quats.shape}")
        if np.asarray(self.centre_m).shape not in ((3,), (len(q), 3)) or not self.radius_m > 0.0:
            raise ValueError("centre_m must be 3 numbers (or one row per touch) and radius_m > 0")
        object.__setattr__(self, "q_rad", q)
        object.__setattr__(self, "body_quat_wxyz", quats)
        object.__setattr__(self, "centre_m", np.asarray(self.centre_m, float))


@dataclass(frozen=True)
class FitResult:
    """Outcome of :func:`fit_joint_offsets`.

    Attributes
    ----------
    offset_rad : (dof,) float
        Estimated encoder offsets (reading minus true angle), radians.
    residual_before_m, residual_after_m : (n,) float
        Signed distance of each computed pad point from the sphere, without and with the offsets.
    singular_values : (dof,) float
        Of the residuals' Jacobian at the solution (metres per radian): a near-zero one marks an
        offset combination these touches cannot see.
    """

    offset_rad: np.ndarray
    residual_before_m: np.ndarray
    residual_after_m: np.ndarray
    singular_values: np.ndarray


def sphere_residuals_m(kinematics, touches: SphereTouches, offset_rad) -> np.ndarray:
    """Signed distance (n,) of each touch's computed pad point from the sphere, metres."""
    q = touches.q_rad - np.asarray(offset_rad, float)
    points = kinematics.pad_position_from_orientation(q, touches.body_quat_wxyz)
    return np.linalg.norm(points - touches.centre_m, axis=1) - touches.radius_m


def fit_joint_offsets(kinematics, touches: SphereTouches, ridge_m_per_rad: float = 0.02) -> FitResult:
    """Least-squares joint offsets from sphere touches (module docstring).

    Parameters
    ----------
    kinematics : robots.kinematics.ArmKinematics
        The nominal model the loop uses.
    touches : SphereTouches
    ridge_m_per_rad : float
        Weight of the ridge term pulling each offset towards zero (metres of residual per radian).
    """
    from scipy.optimize import least_squares

    dof = touches.q_rad.shape[1]
    if len(touches.q_rad) < dof:
        raise ValueError(f"{len(touches.q_rad)} touches cannot determine {dof} joint offsets; touch at least "
                         f"{dof} (better 3 x {dof}) poses")

    def residuals(offset):
        return np.concatenate([sphere_residuals_m(kinematics, touches, offset), ridge_m_per_rad * offset])

    solution = least_squares(residuals, np.zeros(dof), method="trf", x_scale=0.01, diff_step=1e-6)
    singular = np.linalg.svd(solution.jac[: len(touches.q_rad)], compute_uv=False)
    return FitResult(offset_rad=solution.x, residual_before_m=sphere_residuals_m(kinematics, touches, np.zeros(dof)),
                     residual_after_m=sphere_residuals_m(kinematics, touches, solution.x),
                     singular_values=singular)


class CalibratedRobot(Robot):
    """A robot whose encoder offsets are known: readings are corrected and commands shifted to match.

    ``joint_positions() = inner.joint_positions() - offset`` and every commanded position is sent as
    ``q + offset``, so the nominal kinematics of the corrected angles is the true pose.
    Other attributes are the inner robot's.
    """

    def __init__(self, inner: Robot, offset_rad) -> None:
        self.inner = inner
        self.offset_rad = np.asarray(offset_rad, float)
        if self.offset_rad.shape != (inner.dof,):
            raise ValueError(f"offset_rad must have {inner.dof} values, got {self.offset_rad.shape}")

    def __getattr__(self, name):
        return getattr(self.inner, name)

    @property
    def dof(self) -> int:
        return self.inner.dof

    def joint_positions(self) -> np.ndarray:
        return self.inner.joint_positions() - self.offset_rad

    def move_joints(self, q, speed_rad_s: float = 1.0) -> None:
        self.inner.move_joints(np.asarray(q, float) + self.offset_rad, speed_rad_s)

    def guarded_move(self, path, stop: Callable[[], bool], speed_rad_s: float = 0.2) -> GuardedMoveResult:
        result = self.inner.guarded_move(np.asarray(path, float) + self.offset_rad, stop, speed_rad_s)
        return GuardedMoveResult(stopped=result.stopped, q=result.q - self.offset_rad,
                                 waypoint_index=result.waypoint_index)

    def hold(self, duration_s: float, stop: Callable[[], bool] | None = None) -> GuardedMoveResult:
        result = self.inner.hold(duration_s, stop)
        return GuardedMoveResult(stopped=result.stopped, q=result.q - self.offset_rad,
                                 waypoint_index=result.waypoint_index)

    def time_s(self) -> float:
        return self.inner.time_s()
