"""The test rig: a robot from the registry, its pad's fixed approach line and the joint path along it.

Every press of the evaluation starts at the robot's home pose and moves the pad face centre along
its own axis (the approach direction); objects are posed around that line (see
:mod:`explorer.sensor_evaluation.scene`). The inverse kinematics of the line is solved once per rig.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robots.fingertip import FingertipGeometry
from robots.spec import RobotSpec

MAX_JOINT_STEP_RAD_PER_M = 50.0
"""Neighbouring IK waypoints further apart than this (rad of the fastest joint per metre of pad
travel) mean the solver switched posture; the arm would swing instead of sliding along the line."""


@dataclass(frozen=True)
class ApproachLine:
    """The pad's straight approach from the home pose and the joint path that follows it.

    Attributes
    ----------
    start_m : (3,) float
        Pad face centre at home (forward kinematics, springs at rest), world frame, metres.
    direction : (3,) float
        Unit approach direction (the pad's +z face axis at home), world frame.
    face_axes : (3, 2) float
        The pad face's x and y axes at home, world frame.
    depths_m : (k,) float
        Distance of each waypoint from ``start_m`` along ``direction``, metres, increasing from 0.
    q_rad : (k, dof) float
        Joint positions putting the pad face centre at each depth, radians.
    """

    start_m: np.ndarray
    direction: np.ndarray
    face_axes: np.ndarray
    depths_m: np.ndarray
    q_rad: np.ndarray

    @property
    def rad_per_m(self) -> float:
        """Largest joint travel per metre of pad travel along the line, rad/m."""
        steps = np.abs(np.diff(self.q_rad, axis=0)).max(axis=1)
        return float(np.max(steps / np.diff(self.depths_m)))

    def joint_speed_rad_s(self, pad_speed_mps: float) -> float:
        """The guarded-move speed (fastest joint, rad/s) that moves the pad at ``pad_speed_mps``."""
        if not pad_speed_mps > 0.0:
            raise ValueError(f"pad speed must be > 0 m/s, got {pad_speed_mps}")
        return pad_speed_mps * self.rad_per_m

    def index_before(self, depth_m: float) -> int:
        """Index of the deepest waypoint not beyond ``depth_m`` (0 if none)."""
        return max(int(np.searchsorted(self.depths_m, depth_m, side="right")) - 1, 0)

    def face_points_m(self, width_m: float, n: int = 5) -> np.ndarray:
        """(n*n, 3) points spread over the square pad face at home, world frame, metres."""
        offsets = np.linspace(-width_m / 2.0, width_m / 2.0, n)
        u, v = np.meshgrid(offsets, offsets)
        return self.start_m + np.stack([u.ravel(), v.ravel()], axis=1) @ self.face_axes.T


@dataclass(frozen=True)
class PressRig:
    """A robot spec with its approach line (plain data; each trial builds its own world).

    Attributes
    ----------
    spec : RobotSpec
    line : ApproachLine
    pad_width_m : float
        Side of the square pad face, metres.
    spring_friction_nm : float
        Friction torque of the spring joints of the simulated arm, N m (a profile's).
    """

    spec: RobotSpec
    line: ApproachLine
    pad_width_m: float
    spring_friction_nm: float = 0.0


def build_rig(robot: str = "armar3", max_depth_m: float = 0.045, spacing_m: float = 0.001) -> PressRig:
    """Load ``robot`` and solve the IK of its pad's approach line once.

    Parameters
    ----------
    robot : str
        A name from :func:`robots.names` (or a robot spec .json path).
    max_depth_m : float
        How far along the line the path reaches, metres.
    spacing_m : float
        Waypoint spacing along the line, metres.

    Raises
    ------
    ValueError
        Unknown robot, bad lengths.
    RuntimeError
        When some waypoint of the line is out of the arm's reach.
    """
    import robots
    from robots.ik import solve_pad_ik
    from robots.kinematics import ArmKinematics

    if not (max_depth_m > 0.0 and 0.0 < spacing_m <= max_depth_m):
        raise ValueError(f"need 0 < spacing_m <= max_depth_m, got {spacing_m}, {max_depth_m}")
    spec = robots.load(robot)
    kinematics = ArmKinematics(spec)
    home = kinematics.forward_kinematics(spec.home_q)
    direction = home.z_axis
    depths = np.linspace(0.0, max_depth_m, int(round(max_depth_m / spacing_m)) + 1)
    points = home.position_m + depths[:, None] * direction
    ik = solve_pad_ik(kinematics, points, np.tile(direction, (len(depths), 1)), q_seed=spec.home_q)
    if not ik.success.all():
        bad = np.flatnonzero(~ik.success)
        raise RuntimeError(f"{spec.name}: the approach line leaves the reachable workspace at depths "
                           f"{np.round(depths[bad] * 1e3, 1).tolist()} mm")
    q = ik.q_rad.copy()
    q[0] = spec.home_q
    jumps = np.abs(np.diff(q, axis=0)).max(axis=1)
    if jumps.max() > MAX_JOINT_STEP_RAD_PER_M * spacing_m:
        raise RuntimeError(f"{spec.name}: the IK of the approach line switches posture "
                           f"(a {np.degrees(jumps.max()):.1f} deg joint step between neighbouring waypoints)")
    line = ApproachLine(home.position_m, direction, home.rotation[:, :2], depths, q)
    return PressRig(spec, line, FingertipGeometry().body_width_m)
