"""Robot arms with a compliant tactile fingertip: specs, kinematics, IK and the PyBullet arm.

Public API (see robots/README.md):

* specs: :func:`load`, :func:`names`, :func:`register`, :class:`RobotSpec`;
* kinematics: :class:`ArmKinematics` (FK/Jacobian from the URDF), :class:`PadIK` / :func:`solve_pad_ik`,
  :class:`ArmSpheres` (the URDF's collision shapes as spheres placed by FK, for planning);
* simulation: :class:`SimWorld`, :class:`TableSpec`, :class:`ObjectHandle`, :class:`SimArm`,
  :class:`EncoderModel`, :class:`ArmContact`, :func:`measure_pad_compliance_m_per_n` and
  :func:`measure_pad_point_compliance_m_per_n` (the simulated pad's compression per newton on a
  flat plate and on one point).

Heavy modules (torch, pybullet) are imported on first use of their names, so that importing
``robots.interface`` stays light.
"""
from __future__ import annotations

from common.lazy_exports import lazy_exports
from robots.registry import RobotRegistry, load, names, register
from robots.spec import RobotSpec

_LAZY = {
    "ArmKinematics": "robots.kinematics",
    "LinkPoses": "robots.kinematics",
    "ArmSpheres": "robots.link_spheres",
    "ArmShapes": "robots.link_shapes",
    "PadIK": "robots.ik",
    "IKOptions": "robots.ik",
    "IKResult": "robots.ik",
    "solve_pad_ik": "robots.ik",
    "SimWorld": "robots.sim_world",
    "TableSpec": "robots.sim_world",
    "ObjectHandle": "robots.sim_world",
    "SimArm": "robots.sim_arm",
    "EncoderModel": "robots.sim_arm",
    "ArmContact": "robots.sim_arm",
    "MoveNotReachedError": "robots.interface",
    "CalibratedRobot": "robots.joint_calibration",
    "SphereTouches": "robots.joint_calibration",
    "fit_joint_offsets": "robots.joint_calibration",
    "cross_validated_ridge": "robots.joint_calibration",
    "RidgeChoice": "robots.joint_calibration",
    "measure_pad_compliance_m_per_n": "robots.pad_compliance",
    "measure_pad_point_compliance_m_per_n": "robots.pad_compliance",
}

__all__ = ["RobotRegistry", "RobotSpec", "load", "names", "register", *_LAZY]

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)
