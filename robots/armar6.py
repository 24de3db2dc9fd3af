"""An 8-DOF right arm in the style of ARMAR-6, on a fixed torso, as URDF data.

Same torso frame convention as :mod:`robots.armar3` (x forward, y left, z up, origin on the floor
under the torso centre). Compared with ARMAR-III it has a longer reach and an extra shoulder joint:

* ``clavicle`` (axis +z at y = -100 mm, ``SHOULDER_HEIGHT_M`` high; positive swings the shoulder
  forward) carrying the shoulder 160 mm further out;
* ``shoulder_1`` (flexion, +y), ``shoulder_2`` (abduction, -x), ``upper_arm`` (+z), meeting at the
  shoulder centre;
* ``elbow`` (+y, negative flexes forward) 350 mm below the shoulder;
* ``forearm`` (+z), ``wrist_1`` (+y) and ``wrist_2`` (+x) 310 mm below the elbow;
* tool point 150 mm further; ``tool`` +z points out of the hand.

Masses, limits and efforts are plausible values for an arm of this size, not published data.
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

NAME = "armar6"
SHOULDER_HEIGHT_M = 1.40
CLAVICLE_Y_M = -0.100
CLAVICLE_LENGTH_M = 0.160
UPPER_ARM_LENGTH_M = 0.350
FOREARM_LENGTH_M = 0.310
HAND_LENGTH_M = 0.150

JOINT_NAMES = ("clavicle", "shoulder_1", "shoulder_2", "upper_arm", "elbow", "forearm", "wrist_1", "wrist_2")
LIMITS_DEG = (
    (-30.0, 60.0),
    (-180.0, 60.0),
    (-20.0, 130.0),
    (-160.0, 160.0),
    (-150.0, 5.0),
    (-170.0, 170.0),
    (-60.0, 60.0),
    (-45.0, 60.0),
)
LINK_MASSES_KG = (3.0, 3.2, 2.9, 2.7, 2.2, 2.0, 1.1, 0.9)
EFFORT_NM = (150.0, 150.0, 150.0, 100.0, 100.0, 40.0, 20.0, 20.0)
VELOCITY_RAD_S = (1.0, 1.5, 1.5, 2.0, 2.0, 2.5, 3.0, 3.0)
JOINT_DAMPING = 0.5

_WHITE = (0.92, 0.92, 0.92, 1.0)
_DARK = (0.3, 0.3, 0.35, 1.0)


def _limits(index: int) -> dict:
    lower, upper = LIMITS_DEG[index]
    return dict(kind="revolute", lower=math.radians(lower), upper=math.radians(upper),
                effort=EFFORT_NM[index], velocity=VELOCITY_RAD_S[index], damping=JOINT_DAMPING)


def arm_links() -> tuple[Link, ...]:
    """The torso and the eight arm links, torso first."""
    m = LINK_MASSES_KG
    height = SHOULDER_HEIGHT_M + 0.15
    return (
        Link("torso", 60.0, shapes=(Shape(Box((0.30, 0.20, height)), xyz=(-0.03, 0.0, height / 2.0)),),
             rgba=_DARK),
        Link("clavicle_link", m[0], shapes=(
            Shape(Box((0.08, CLAVICLE_LENGTH_M, 0.08)), xyz=(0.0, -CLAVICLE_LENGTH_M / 2.0, 0.0)),
        ), rgba=_WHITE),
        Link("shoulder_1_link", m[1], shapes=(cylinder_across(0.06, 0.11, "y"),), rgba=_WHITE),
        Link("shoulder_2_link", m[2], shapes=(Shape(Sphere(0.06)),), rgba=_WHITE),
        Link("upper_arm_link", m[3], shapes=(cylinder_along_z(0.05, -0.07, -0.30),), rgba=_WHITE),
        Link("elbow_link", m[4], shapes=(cylinder_across(0.05, 0.09, "y"),), rgba=_WHITE),
        Link("forearm_link", m[5], shapes=(cylinder_along_z(0.045, -0.055, -0.27),), rgba=_WHITE),
        Link("wrist_1_link", m[6], shapes=(cylinder_across(0.035, 0.07, "y"),), rgba=_WHITE),
        Link("wrist_2_link", m[7], shapes=(
            Shape(Box((0.070, 0.035, 0.080)), xyz=(0.0, 0.0, -0.065)),
            cylinder_along_z(0.009, -0.105, -HAND_LENGTH_M),
        ), rgba=_WHITE),
        Link(TOOL_LINK, 0.001),
    )


def arm_joints() -> tuple[Joint, ...]:
    """The eight actuated joints plus the fixed tool frame."""
    return (
        Joint("clavicle", parent="torso", child="clavicle_link",
              xyz=(0.0, CLAVICLE_Y_M, SHOULDER_HEIGHT_M), axis=(0.0, 0.0, 1.0), **_limits(0)),
        Joint("shoulder_1", parent="clavicle_link", child="shoulder_1_link",
              xyz=(0.0, -CLAVICLE_LENGTH_M, 0.0), axis=(0.0, 1.0, 0.0), **_limits(1)),
        Joint("shoulder_2", parent="shoulder_1_link", child="shoulder_2_link",
              axis=(-1.0, 0.0, 0.0), **_limits(2)),
        Joint("upper_arm", parent="shoulder_2_link", child="upper_arm_link",
              axis=(0.0, 0.0, 1.0), **_limits(3)),
        Joint("elbow", parent="upper_arm_link", child="elbow_link",
              xyz=(0.0, 0.0, -UPPER_ARM_LENGTH_M), axis=(0.0, 1.0, 0.0), **_limits(4)),
        Joint("forearm", parent="elbow_link", child="forearm_link",
              axis=(0.0, 0.0, 1.0), **_limits(5)),
        Joint("wrist_1", parent="forearm_link", child="wrist_1_link",
              xyz=(0.0, 0.0, -FOREARM_LENGTH_M), axis=(0.0, 1.0, 0.0), **_limits(6)),
        Joint("wrist_2", parent="wrist_1_link", child="wrist_2_link",
              axis=(1.0, 0.0, 0.0), **_limits(7)),
        Joint("hand_to_tool", "fixed", "wrist_2_link", TOOL_LINK,
              xyz=(0.0, 0.0, -HAND_LENGTH_M), rpy=(math.pi, 0.0, 0.0)),
    )


def model(fingertip: FingertipGeometry = FingertipGeometry()) -> RobotModel:
    """The complete ARMAR-6-style arm with the compliant fingertip."""
    tip_links, tip_joints = fingertip_parts(TOOL_LINK, fingertip)
    return RobotModel(NAME, arm_links() + tip_links, arm_joints() + tip_joints)
