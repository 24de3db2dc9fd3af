"""Object positioners: a rotating stand whose known angles carry contacts into the object frame.

One arm on a fixed torso cannot reach around an object. A turntable (yaw about the vertical) on a
tilt stage (quarter turns about a horizontal axis, as a person laying the object on its side or
upside down) brings every side within reach: the ARMAR-III wrist cannot point the pad straight down
or up, so faces whose normal is vertical are reached after a quarter tilt. The loop only sees :class:`Positioner`: the angles it
may choose and the object pose they produce; the simulated stand moves the PyBullet body, a real
one drives a motor or asks a person.

Pose convention: ``x_world = centre + Rz(yaw) Rx(tilt) x_object``.
"""
from __future__ import annotations

import abc
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class StandPose:
    """Angles of the stand, radians."""

    yaw_rad: float = 0.0
    tilt_rad: float = 0.0


def stand_rotation(pose: StandPose) -> np.ndarray:
    """(3, 3) rotation object -> world for the stand angles."""
    cy, sy = np.cos(pose.yaw_rad), np.sin(pose.yaw_rad)
    cf, sf = np.cos(pose.tilt_rad), np.sin(pose.tilt_rad)
    rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cf, -sf], [0.0, sf, cf]])
    return rz @ rx


class Positioner(abc.ABC):
    """A stand holding the object at ``centre_m`` (world) in a pose set by :class:`StandPose`.

    Attributes
    ----------
    centre_m : (3,) float
        World position of the object-frame origin, metres.
    poses : tuple of StandPose
        The poses the loop may choose from.
    """

    centre_m: np.ndarray
    poses: tuple[StandPose, ...]

    @abc.abstractmethod
    def pose(self) -> StandPose:
        """The current (known) stand angles."""

    @abc.abstractmethod
    def move_to(self, pose: StandPose) -> None:
        """Turn the stand; the arm must be clear of the object."""

    def object_to_world(self, pose: StandPose | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(R (3, 3), t (3,)) with ``x_world = R x_object + t``."""
        return stand_rotation(self.pose() if pose is None else pose), np.asarray(self.centre_m, float)

    def to_object(self, points_world: np.ndarray, directions_world: np.ndarray | None = None):
        """World points (n, 3) (and directions) in the object frame at the current pose."""
        R, t = self.object_to_world()
        points = (np.asarray(points_world, float) - t) @ R
        if directions_world is None:
            return points
        return points, np.asarray(directions_world, float) @ R

    def to_world(self, points_object: np.ndarray, directions_object: np.ndarray | None = None,
                 pose: StandPose | None = None):
        """Object-frame points (n, 3) (and directions) in the world at ``pose`` (default: current)."""
        R, t = self.object_to_world(pose)
        points = np.asarray(points_object, float) @ R.T + t
        if directions_object is None:
            return points
        return points, np.asarray(directions_object, float) @ R.T


def turntable_poses(yaw_steps: int = 12, tilt_steps: int = 4) -> tuple[StandPose, ...]:
    """Evenly spaced yaw angles, each at ``tilt_steps`` evenly spaced tilts (1: upright only)."""
    if yaw_steps < 1 or tilt_steps < 1:
        raise ValueError(f"yaw_steps and tilt_steps must be >= 1, got {yaw_steps}, {tilt_steps}")
    yaws = 2 * np.pi * np.arange(yaw_steps) / yaw_steps
    tilts = 2 * np.pi * np.arange(tilt_steps) / tilt_steps
    return tuple(StandPose(float(y), float(t)) for t in tilts for y in yaws)


class FixedStand(Positioner):
    """No positioner: the object stays in one pose."""

    def __init__(self, centre_m, pose: StandPose = StandPose()):
        self.centre_m = np.asarray(centre_m, float)
        self._pose = pose
        self.poses = (pose,)

    def pose(self) -> StandPose:
        return self._pose

    def move_to(self, pose: StandPose) -> None:
        if pose != self._pose:
            raise ValueError(f"a fixed stand cannot move to {pose}")


class SimulatedStand(Positioner):
    """A turntable on a tilt stage in the simulator: re-poses the (static) object body.

    The stand's own structure is not simulated: the object is held rigidly at ``centre_m`` with
    nothing occluding it.

    Parameters
    ----------
    set_object_pose : callable (position (3,), quat_wxyz (4,)) -> None
        Moves the object body in the world (a closure over the simulator, so this class never
        holds a simulator handle).
    centre_m : (3,) float
    poses : tuple of StandPose
    """

    def __init__(self, set_object_pose, centre_m, poses=turntable_poses()):
        self._set = set_object_pose
        self.centre_m = np.asarray(centre_m, float)
        self.poses = tuple(poses)
        self._pose = StandPose()
        self.move_to(self._pose)

    def pose(self) -> StandPose:
        return self._pose

    def move_to(self, pose: StandPose) -> None:
        from common.rotations import matrix_to_quat

        self._set(self.centre_m, matrix_to_quat(stand_rotation(pose)))
        self._pose = pose
