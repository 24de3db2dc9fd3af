"""ARMAR-III right arm on a fixed torso, as URDF data.

Kinematics from the published ARMAR-III figures, expressed in a ROS-style torso frame
(x forward, y left, z up; the torso frame sits on the floor under the torso centre):

* shoulder centre at y = -232 mm (right side), ``SHOULDER_HEIGHT_M`` above the floor;
* ``shoulder_1`` (flexion, axis +y, negative lifts the arm forward), ``shoulder_2`` (abduction,
  axis -x, positive lifts the arm outward), ``upper_arm`` (rotation about the upper arm, +z);
  the three axes meet at the shoulder centre;
* ``elbow`` (axis +y, negative flexes the forearm forward) at a = 20 mm forward, d = -310 mm;
* ``forearm`` (rotation about the forearm, +z) offset d = 7.5 mm along the elbow axis (outward);
* ``wrist_1`` (axis +y) and ``wrist_2`` (axis +x) at d = -240 mm below the elbow;
* tool point 130 mm further along the hand; the ``tool`` frame is turned so that its +z points
  out of the hand (straight down at zero joint angles).

Zero joint angles: the arm hangs straight down. Joint limits are the published right-arm limits;
link masses are the published ones, inertias follow from the collision shapes (capsule-like
cylinders, spheres, boxes). The shoulder height of 1.30 m puts table tops at 0.75-0.95 m within
reach with the fingertip pointing down (see ``robots.registry``).
"""
from __future__ import annotations

import math

from robots.fingertip import TOOL_LINK, FingertipGeometry, fingertip_parts
from robots.urdf_model import (
    Box,
    Joint,
    Link,
    RobotModel,
    Shape,
    Sphere,
    cylinder_across,
    cylinder_along_z,
)

NAME = "armar3"
SHOULDER_HEIGHT_M = 1.30
SHOULDER_Y_M = -0.232
UPPER_ARM_OFFSET_M = 0.020
UPPER_ARM_LENGTH_M = 0.310
ELBOW_OFFSET_M = 0.0075
FOREARM_LENGTH_M = 0.240
HAND_LENGTH_M = 0.130

JOINT_NAMES = ("shoulder_1", "shoulder_2", "upper_arm", "elbow", "forearm", "wrist_1", "wrist_2")
LIMITS_DEG = (
    (-106.94, 80.0),
    (-13.85, 94.62),
    (-108.11, 73.94),
    (-114.58, 55.0),
    (-69.65, 108.25),
    (-29.18, 29.88),
    (-30.9, 50.87),
)
LINK_MASSES_KG = (3.65, 2.5, 1.56, 1.16, 2.27, 1.30, 0.2)
EFFORT_NM = (80.0, 80.0, 40.0, 40.0, 20.0, 10.0, 10.0)
VELOCITY_RAD_S = (1.5, 1.5, 2.0, 2.0, 2.5, 3.0, 3.0)
JOINT_DAMPING = 0.5

_GREY = (0.75, 0.75, 0.78, 1.0)
_DARK = (0.35, 0.35, 0.4, 1.0)


def _limits(index: int) -> dict:
    lower, upper = LIMITS_DEG[index]
    return dict(kind="revolute", lower=math.radians(lower), upper=math.radians(upper),
                effort=EFFORT_NM[index], velocity=VELOCITY_RAD_S[index], damping=JOINT_DAMPING)


def arm_links() -> tuple[Link, ...]:
    """The torso and the seven arm links, torso first."""
    m = LINK_MASSES_KG
    torso = Link("torso", 30.0, shapes=(
        Shape(Box((0.22, 0.30, SHOULDER_HEIGHT_M + 0.10)), xyz=(-0.02, 0.0, (SHOULDER_HEIGHT_M + 0.10) / 2.0)),
    ), rgba=_DARK)
    return (
        torso,
        Link("shoulder_1_link", m[0], shapes=(cylinder_across(0.06, 0.10, "y"),), rgba=_GREY),
        Link("shoulder_2_link", m[1], shapes=(Shape(Sphere(0.055)),), rgba=_GREY),
        Link("upper_arm_link", m[2], shapes=(cylinder_along_z(0.045, -0.06, -0.27),), rgba=_GREY),
        Link("elbow_link", m[3], shapes=(cylinder_across(0.045, 0.08, "y"),), rgba=_GREY),
        Link("forearm_link", m[4], shapes=(cylinder_along_z(0.040, -0.05, -0.205),), rgba=_GREY),
        Link("wrist_1_link", m[5], shapes=(cylinder_across(0.035, 0.06, "y"),), rgba=_GREY),
        Link("wrist_2_link", m[6], shapes=(
            Shape(Box((0.060, 0.030, 0.070)), xyz=(0.0, 0.0, -0.060)),
            cylinder_along_z(0.008, -0.095, -HAND_LENGTH_M),
        ), rgba=_GREY),
        Link(TOOL_LINK, 0.001),
    )


def arm_joints() -> tuple[Joint, ...]:
    """The seven actuated joints plus the fixed tool frame."""
    return (
        Joint("shoulder_1", parent="torso", child="shoulder_1_link",
              xyz=(0.0, SHOULDER_Y_M, SHOULDER_HEIGHT_M), axis=(0.0, 1.0, 0.0), **_limits(0)),
        Joint("shoulder_2", parent="shoulder_1_link", child="shoulder_2_link",
              axis=(-1.0, 0.0, 0.0), **_limits(1)),
        Joint("upper_arm", parent="shoulder_2_link", child="upper_arm_link",
              axis=(0.0, 0.0, 1.0), **_limits(2)),
        Joint("elbow", parent="upper_arm_link", child="elbow_link",
              xyz=(UPPER_ARM_OFFSET_M, 0.0, -UPPER_ARM_LENGTH_M), axis=(0.0, 1.0, 0.0), **_limits(3)),
        Joint("forearm", parent="elbow_link", child="forearm_link",
              xyz=(0.0, -ELBOW_OFFSET_M, 0.0), axis=(0.0, 0.0, 1.0), **_limits(4)),
        Joint("wrist_1", parent="forearm_link", child="wrist_1_link",
              xyz=(0.0, 0.0, -FOREARM_LENGTH_M), axis=(0.0, 1.0, 0.0), **_limits(5)),
        Joint("wrist_2", parent="wrist_1_link", child="wrist_2_link",
              axis=(1.0, 0.0, 0.0), **_limits(6)),
        Joint("hand_to_tool", "fixed", "wrist_2_link", TOOL_LINK,
              xyz=(0.0, 0.0, -HAND_LENGTH_M), rpy=(math.pi, 0.0, 0.0)),
    )


def model(fingertip: FingertipGeometry = FingertipGeometry()) -> RobotModel:
    """The complete ARMAR-III right arm with the compliant fingertip."""
    tip_links, tip_joints = fingertip_parts(TOOL_LINK, fingertip)
    return RobotModel(NAME, arm_links() + tip_links, arm_joints() + tip_joints)
