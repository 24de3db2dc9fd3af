"""The simulated pad's compression per newton, measured the way a lab measures a real pad's.

A lab presses its fingertip flat onto a rigid plate at two forces and reads how far the pad face
moved between them. :func:`measure_pad_compliance_m_per_n` does that with the simulated arm: the
pad's contact softness is a PyBullet parameter per contact point (``RobotSpec.
pad_contact_stiffness_n_per_m``), and what a flat face of four corner contacts compresses per
newton also depends on the solver (measured: 1.5-1.6 x ``1 / (4 k)`` at 1/480 s steps), so it is
read off the physics rather than computed. The contact pipeline adds ``force x compliance`` back
along the normal (:class:`sensor.pad_calibration.PadCalibration`); with the wrong compliance every
contact sits that much off the surface, in or out, growing with the force.
"""
from __future__ import annotations

import tempfile
from functools import lru_cache
from pathlib import Path

import numpy as np

#: The two press forces, newtons: the loop's presses end at 1.5 N, its re-presses at 3 N.
PRESS_FORCES_N = (1.0, 3.0)
#: Where the plate's face lies ahead of the pad at the arm's home pose, and how deep the press may go, metres.
PLATE_GAP_M = 0.02
PRESS_DEPTH_M = 0.04
#: Physics steps held at each force before reading (the pad settles within about 60).
HOLD_STEPS = 240


def measure_pad_compliance_m_per_n(spec) -> float:
    """The pad's compression per newton on a flat plate, metres per newton.

    Parameters
    ----------
    spec : robots.spec.RobotSpec
        The simulated robot, with the pad's contact parameters the simulation uses.

    Returns
    -------
    float
        Slope of the pad face's depth into the plate against the contact force between the two
        :data:`PRESS_FORCES_N`, metres per newton. Cached per spec (a few seconds of physics).
    """
    return _measured(spec)


@lru_cache(maxsize=16)
def _measured(spec) -> float:
    from common.rotations import matrix_to_quat
    from robots.ik import solve_pad_ik
    from robots.kinematics import ArmKinematics
    from robots.sim_arm import SimArm
    from robots.sim_world import SimWorld
    from robots.urdf_model import Box, Link, RobotModel, Shape, to_urdf

    kinematics = ArmKinematics(spec)
    home = kinematics.forward_kinematics(spec.home_q)
    normal = -home.z_axis  # the plate faces the pad head on
    face_centre = home.position_m + PLATE_GAP_M * home.z_axis
    points = home.position_m + np.linspace(0.0, PLATE_GAP_M + PRESS_DEPTH_M, 41)[:, None] * home.z_axis
    path = solve_pad_ik(kinematics, points, np.tile(home.z_axis, (len(points), 1)), q_seed=spec.home_q)
    if not path.success.all():
        raise RuntimeError(f"{spec.name}: no straight press from the home pose to measure the pad's compliance")
    thickness = 0.05
    with tempfile.TemporaryDirectory() as directory, SimWorld(table=None) as world:
        urdf = Path(directory) / "plate.urdf"
        urdf.write_text(to_urdf(RobotModel("plate", (Link("plate", 1.0, shapes=(Shape(Box((0.2, 0.2, thickness))),)),))))
        frame = home.rotation @ np.diag([1.0, -1.0, -1.0])  # the pad's frame turned to face it: +z = normal
        world.add_object(urdf, face_centre - 0.5 * thickness * normal, matrix_to_quat(frame), name="plate")
        arm = SimArm(world, spec)
        forces, depths = [], []
        for target in PRESS_FORCES_N:
            result = arm.guarded_move(path.q_rad, lambda: arm.pad_state().normal_force_n > target, speed_rad_s=0.02)
            if not result.stopped:
                raise RuntimeError(f"{spec.name}: the press never reached {target} N on the plate")
            world.step(HOLD_STEPS)
            forces.append(arm.pad_state().normal_force_n)
            depths.append(-float(np.dot(arm.link_state(spec.pad_link).position_m - face_centre, normal)))
    return float((depths[1] - depths[0]) / (forces[1] - forces[0]))
