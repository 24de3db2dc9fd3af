"""Named, float64 views of PyBullet's raw result tuples (used inside robots/ only)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from common.rotations import matrix_to_quat, quat_to_matrix, xyzw_to_wxyz

JOINT_TYPE_NAMES = {0: "revolute", 1: "prismatic", 2: "spherical", 3: "planar", 4: "fixed"}


@dataclass(frozen=True)
class JointInfo:
    """Static description of one joint (``getJointInfo``); its child link shares its index."""

    index: int
    name: str
    kind: str
    child_link_name: str
    parent_index: int
    lower_rad: float
    upper_rad: float
    effort_nm: float
    velocity_rad_s: float
    axis: np.ndarray

    @classmethod
    def from_pybullet(cls, raw: tuple) -> "JointInfo":
        return cls(
            index=raw[0],
            name=raw[1].decode(),
            kind=JOINT_TYPE_NAMES.get(raw[2], str(raw[2])),
            child_link_name=raw[12].decode(),
            parent_index=int(raw[16]),
            lower_rad=float(raw[8]),
            upper_rad=float(raw[9]),
            effort_nm=float(raw[10]),
            velocity_rad_s=float(raw[11]),
            axis=np.asarray(raw[13], dtype=float),
        )


@dataclass(frozen=True)
class JointState:
    """Position (rad) and velocity (rad/s) of one joint (``getJointState``)."""

    position_rad: float
    velocity_rad_s: float

    @classmethod
    def from_pybullet(cls, raw: tuple) -> "JointState":
        return cls(float(raw[0]), float(raw[1]))


@dataclass(frozen=True)
class LinkState:
    """Pose and velocity of a link's URDF frame in the world.

    PyBullet reports the link frame pose in single precision but the centre-of-mass pose and the
    local inertial offset in double; the frame is rebuilt from the latter to keep float64 accuracy.

    Attributes
    ----------
    position_m : (3,) float, world frame, metres
    quat_wxyz : (4,) float, world frame
    lin_vel_mps : (3,) float, velocity of the frame origin, world frame
    ang_vel_radps : (3,) float, world frame
    """

    position_m: np.ndarray
    quat_wxyz: np.ndarray
    lin_vel_mps: np.ndarray
    ang_vel_radps: np.ndarray

    @property
    def rotation(self) -> np.ndarray:
        """(3, 3) rotation matrix, link frame -> world."""
        return quat_to_matrix(self.quat_wxyz)

    @classmethod
    def from_pybullet(cls, raw: tuple) -> "LinkState":
        """From ``getLinkState(..., computeLinkVelocity=1, computeForwardKinematics=1)``."""
        com_position = np.asarray(raw[0], dtype=float)
        com_vel = np.asarray(raw[6], dtype=float) if len(raw) > 6 else np.zeros(3)
        ang_vel = np.asarray(raw[7], dtype=float) if len(raw) > 7 else np.zeros(3)
        if raw[2] == (0.0, 0.0, 0.0) and raw[3] == (0.0, 0.0, 0.0, 1.0):  # frame = centre of mass
            quat = xyzw_to_wxyz(raw[1])
            return cls(com_position, quat / np.linalg.norm(quat), com_vel, ang_vel)
        com_rotation = quat_to_matrix(xyzw_to_wxyz(raw[1]))
        inertial_offset = np.asarray(raw[2], dtype=float)
        inertial_rotation = quat_to_matrix(xyzw_to_wxyz(raw[3]))
        frame_rotation = com_rotation @ inertial_rotation.T
        frame_position = com_position - frame_rotation @ inertial_offset
        frame_vel = com_vel + np.cross(ang_vel, frame_position - com_position)
        if np.array_equal(inertial_rotation, np.eye(3)):
            quat = xyzw_to_wxyz(raw[1])
        else:
            quat = matrix_to_quat(frame_rotation)
        return cls(frame_position, quat / np.linalg.norm(quat), frame_vel, ang_vel)


@dataclass(frozen=True)
class LinkInertia:
    """Mass properties of a link in the world (``getDynamicsInfo`` + ``getLinkState``).

    Attributes
    ----------
    mass_kg : float
    principal_moments_kgm2 : (3,) float, about the centre of mass along the inertial axes
    com_position_m : (3,) float, world frame
    inertial_rotation : (3, 3) float, inertial axes -> world
    """

    mass_kg: float
    principal_moments_kgm2: np.ndarray
    com_position_m: np.ndarray
    inertial_rotation: np.ndarray

    @classmethod
    def from_pybullet(cls, dynamics: tuple, link_state: tuple) -> "LinkInertia":
        return cls(
            mass_kg=float(dynamics[0]),
            principal_moments_kgm2=np.asarray(dynamics[2], dtype=float),
            com_position_m=np.asarray(link_state[0], dtype=float),
            inertial_rotation=quat_to_matrix(xyzw_to_wxyz(link_state[1])),
        )

    def about_axis(self, point_m: np.ndarray, axis: np.ndarray) -> float:
        """Moment of inertia about the line through ``point_m`` along unit ``axis`` (world), kg m^2."""
        rot = self.inertial_rotation
        own = axis @ rot @ np.diag(self.principal_moments_kgm2) @ rot.T @ axis
        return float(own + self.mass_kg * np.linalg.norm(np.cross(self.com_position_m - point_m, axis)) ** 2)


@dataclass(frozen=True)
class ContactPoint:
    """One contact between body A and body B (``getContactPoints``).

    ``normal_on_b`` points from B towards A; with A the arm it is the outward surface normal of
    the touched body B. Positions in world frame, metres; force in newtons.
    """

    body_a: int
    body_b: int
    link_a: int
    link_b: int
    position_on_a_m: np.ndarray
    position_on_b_m: np.ndarray
    normal_on_b: np.ndarray
    distance_m: float
    normal_force_n: float

    @classmethod
    def from_pybullet(cls, raw: tuple) -> "ContactPoint":
        return cls(
            body_a=raw[1],
            body_b=raw[2],
            link_a=raw[3],
            link_b=raw[4],
            position_on_a_m=np.asarray(raw[5], dtype=float),
            position_on_b_m=np.asarray(raw[6], dtype=float),
            normal_on_b=np.asarray(raw[7], dtype=float),
            distance_m=float(raw[8]),
            normal_force_n=float(raw[9]),
        )
