"""The simulated pad's compression per newton, measured the way a lab measures a real pad's.

A lab presses its fingertip flat onto a rigid plate at two forces and reads how far the pad face
moved between them. :func:`measure_pad_compliance_m_per_n` does that with the simulated arm: the
pad's contact softness is a PyBullet parameter per contact point (``RobotSpec.
pad_contact_stiffness_n_per_m``), and what a flat face of four corner contacts compresses per
newton also depends on the solver (measured: 1.5-1.6 x ``1 / (4 k)`` at 1/480 s steps), so it is
read off the physics rather than computed. The contact pipeline adds ``force x compliance`` back
along the normal (:class:`sensor.pad_calibration.PadCalibration`); with the wrong compliance every
contact sits that much off the surface, in or out, growing with the force.

A face pressed on one point sinks further per newton than one pressed flat: on a smooth ball the
simulated pad has one contact point instead of four and sinks 1 / k (0.33 against 0.136 mm/N at
3 kN/m per point; a cylinder's line of contact sinks as the plate does), as a real pad's load
concentrates under a curved body. On a meshed body the face bears on one, two or three vertices.
A lab measures it on its calibration ball the way it measures the plate:
:func:`measure_pad_point_compliance_m_per_n` presses a meshed ball head on at several turns, and
:mod:`explorer.pad_indentation` uses it where the contacts' normals say the surface curves away
from the pad in every direction.
"""
from __future__ import annotations

import tempfile
from functools import lru_cache
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

#: The two press forces, newtons: the loop's presses end at 1.5 N, its re-presses at 3 N.
PRESS_FORCES_N = (1.0, 3.0)
#: Where the plate's face lies ahead of the pad at the arm's home pose, and how deep the press may go, metres.
PLATE_GAP_M = 0.02
PRESS_DEPTH_M = 0.04
#: Physics steps held at each force before reading (the pad settles within about 60).
HOLD_STEPS = 240
#: The ball pressed for the point compliance: radius, metres, and subdivisions of its icosphere
#: (edges of 2.6 mm, as the registry's and the generator's meshes have 2-5 mm: on a tessellated body
#: the face bears on one vertex, two or three, and sinks less per newton than on a smooth one, whose
#: one point gives 1 / k), pressed head on at this many seeded turns; the median slope is taken.
POINT_BALL_RADIUS_M = 0.04
POINT_BALL_SUBDIVISIONS = 4
POINT_BALL_TURNS = 12
#: Where the ball's near point lies ahead of the pad at the home pose, metres (closer than the
#: plate: twelve presses, each from the home pose).
BALL_GAP_M = 0.004


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
    return _measured(spec, False)[0]


def measure_pad_point_compliance_m_per_n(spec) -> float:
    """The pad's compression per newton on a ball, where the face bears on one point of a smooth body
    or on one to three vertices of a tessellated one (:data:`POINT_BALL_RADIUS_M`, head on at
    :data:`POINT_BALL_TURNS` turns), metres per newton; ``spec`` as for
    :func:`measure_pad_compliance_m_per_n`.

    Returns
    -------
    float
        Median over the turns of the slope of the pad face's depth into the ball against the force
        between the two :data:`PRESS_FORCES_N`, metres per newton (the median: a soft pad pressed to
        3 N onto a vertex can sink past the ball's side). Cached per spec (6-11 s of physics).
    """
    return float(np.median(_measured(spec, True)))


def _measured(spec, on_ball: bool) -> tuple[float, ...]:
    """The slopes, metres per newton: on the plate (one), or on the ball at each of its
    :data:`POINT_BALL_TURNS` seeded turns about its centre."""
    if not on_ball:
        return (_slope(spec, None),)
    return tuple(_slope(spec, turn) for turn in range(POINT_BALL_TURNS))


@lru_cache(maxsize=256)
def _slope(spec, ball_turn: int | None) -> float:
    """One press pair's slope: on the plate (``ball_turn`` None) or on the ball turned by the
    seeded rotation ``ball_turn`` (each in a world of its own: a ball re-posed under a reset arm
    did not give the same presses)."""
    from common.rotations import matrix_to_quat
    from robots.sim_arm import SimArm
    from robots.sim_world import SimWorld
    from robots.urdf_model import Box, Link, RobotModel, Shape, to_urdf

    gap = PLATE_GAP_M if ball_turn is None else BALL_GAP_M
    home, path_q = _press_path(spec, gap)
    normal = -home.z_axis  # the plate faces the pad head on
    face_centre = home.position_m + gap * home.z_axis
    frame = home.rotation @ np.diag([1.0, -1.0, -1.0])  # the pad's frame turned to face it: +z = normal
    with tempfile.TemporaryDirectory() as directory, SimWorld(table=None) as world:
        if ball_turn is None:
            name, behind_face = "plate", 0.025  # the plate's centre behind the face
            urdf = Path(directory) / "plate.urdf"
            urdf.write_text(to_urdf(RobotModel(name, (Link(name, 1.0, shapes=(Shape(Box((0.2, 0.2, 2 * behind_face))),)),))))
        else:
            name, behind_face = "ball", POINT_BALL_RADIUS_M
            urdf = _ball_urdf(Path(directory))
            frame = frame @ Rotation.random(random_state=ball_turn).as_matrix()  # turned about its centre
        world.add_object(urdf, face_centre - behind_face * normal, matrix_to_quat(frame), name=name)
        arm = SimArm(world, spec)
        forces, depths = [], []
        for target in PRESS_FORCES_N:
            result = arm.guarded_move(path_q, lambda: arm.pad_state().normal_force_n > target, speed_rad_s=0.02)
            if not result.stopped:
                raise RuntimeError(f"{spec.name}: the press never reached {target} N on the {name}")
            world.step(HOLD_STEPS)
            forces.append(arm.pad_state().normal_force_n)
            depths.append(-float(np.dot(arm.link_state(spec.pad_link).position_m - face_centre, normal)))
    return float((depths[1] - depths[0]) / (forces[1] - forces[0]))


@lru_cache(maxsize=16)
def _press_path(spec, gap_m: float):
    """The home pose's pad frame and the joint path (k, dof) of a straight press along the pad's
    axis from it, ``gap_m`` to the surface and :data:`PRESS_DEPTH_M` beyond (one IK per spec)."""
    from robots.ik import solve_pad_ik
    from robots.kinematics import ArmKinematics

    kinematics = ArmKinematics(spec)
    home = kinematics.forward_kinematics(spec.home_q)
    points = home.position_m + np.linspace(0.0, gap_m + PRESS_DEPTH_M, 41)[:, None] * home.z_axis
    path = solve_pad_ik(kinematics, points, np.tile(home.z_axis, (len(points), 1)), q_seed=spec.home_q)
    if not path.success.all():
        raise RuntimeError(f"{spec.name}: no straight press from the home pose to measure the pad's compliance")
    return home, path.q_rad


def _ball_urdf(directory: Path) -> Path:
    """A static triangle-mesh ball of :data:`POINT_BALL_RADIUS_M` (as objects are simulated: the
    exact mesh, :func:`objects.files.urdf_text`) written into ``directory``; its URDF path."""
    import trimesh

    from objects.files import obj_text, urdf_text

    ball = trimesh.creation.icosphere(subdivisions=POINT_BALL_SUBDIVISIONS, radius=POINT_BALL_RADIUS_M)
    (directory / "ball.obj").write_text(obj_text(ball, "calibration ball, metres"))
    urdf = directory / "ball.urdf"
    urdf.write_text(urdf_text("ball", "ball.obj", (0.8, 0.8, 0.8, 1.0)))
    return urdf
