"""The PyBullet world and arm: passive spring, self-alignment, contact state, guarded moves."""
from __future__ import annotations

import math

import numpy as np
import pybullet
import pytest

import robots
from robots.ik import solve_pad_ik
from robots.interface import GuardedMoveResult, Robot
from robots.kinematics import ArmKinematics
from common.rotations import angle_between_vectors, matrix_to_quat, quat_to_matrix
from robots.sim_arm import PROTECTIVE_STOP_N, EncoderModel, MoveNotReachedError, SimArm
from robots.sim_world import ObjectHandle, SimWorld
from robots.urdf_model import Box, Link, RobotModel, Shape, to_urdf
from common.pad_state import PadState

BOX_SIZE = (0.2, 0.2, 0.1)


@pytest.fixture(scope="module")
def spec():
    return robots.load("armar3")


@pytest.fixture(scope="module")
def kinematics(spec):
    return ArmKinematics(spec)


@pytest.fixture(scope="module")
def box_urdf(tmp_path_factory):
    path = tmp_path_factory.mktemp("objects") / "box.urdf"
    path.write_text(to_urdf(RobotModel("box", (Link("box", 1.0, shapes=(Shape(Box(BOX_SIZE)),)),))))
    return path


@pytest.fixture
def world():
    with SimWorld(table=None) as sim:
        yield sim


def _rotation(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


def _place_tilted_box(world, box_urdf, home, tilt_rad, gap_m=0.02):
    """A box whose top face lies gap_m ahead of the pad, normal tilted from -approach by tilt_rad."""
    approach = home.z_axis
    normal = _rotation(home.rotation[:, 0] + 0.5 * home.rotation[:, 1], tilt_rad) @ (-approach)
    x = np.cross([0.0, 1.0, 0.0], normal)
    x /= np.linalg.norm(x)
    frame = np.stack([x, np.cross(normal, x), normal], axis=1)
    face_centre = home.position_m + gap_m * approach
    world.add_object(box_urdf, face_centre - BOX_SIZE[2] / 2 * normal, matrix_to_quat(frame), name="tilted box")
    return normal, face_centre


def _approach_path(kinematics, home, depth_m, n=9):
    points = home.position_m + np.linspace(0.0, depth_m, n)[:, None] * home.z_axis
    result = solve_pad_ik(kinematics, points, np.tile(home.z_axis, (n, 1)), q_seed=kinematics.spec.home_q)
    assert result.success.all()
    return result.q_rad


# ---- world --------------------------------------------------------------------------------------


def test_world_steps_listeners_and_hooks_in_order(world):
    calls = []
    remove_hook = world.add_pre_step_hook(lambda t: calls.append(("pre", t)))
    remove_listener = world.add_step_listener(lambda t: calls.append(("post", t)))
    world.step(3)
    dt = world.time_step_s
    assert calls == [("pre", dt), ("post", dt), ("pre", 2 * dt), ("post", 2 * dt), ("pre", 3 * dt), ("post", 3 * dt)]
    remove_hook()
    remove_listener()
    world.step(2)
    assert len(calls) == 6 and world.time_s == pytest.approx(5 * dt)


def test_the_tables_box_is_the_simulated_tables_top_and_footprint():
    """``TableSpec.box_m`` (what free moves keep clear of) against PyBullet's own bounding box of
    the table body: same top face and footprint; the box goes down to the floor."""
    with SimWorld() as sim:
        table = next(b for b in range(pybullet.getNumBodies(physicsClientId=sim.client))
                     if sim.body_name(pybullet.getBodyUniqueId(b, physicsClientId=sim.client)) == "table")
        lo, hi = (np.array(v) for v in pybullet.getAABB(table, physicsClientId=sim.client))
        centre, half = (np.array(v) for v in sim.table.box_m())
    margin = 0.005  # PyBullet pads AABBs by its collision margin
    np.testing.assert_allclose(centre[:2] + half[:2], hi[:2], atol=margin)
    np.testing.assert_allclose(centre[:2] - half[:2], lo[:2], atol=margin)
    assert abs(centre[2] + half[2] - hi[2]) < margin and centre[2] - half[2] == 0.0


def test_world_errors_name_the_problem(tmp_path, box_urdf):
    with pytest.raises(ValueError, match="time_step_s"):
        SimWorld(time_step_s=0.1)
    with SimWorld() as sim:
        with pytest.raises(FileNotFoundError, match="missing.urdf"):
            sim.add_object(tmp_path / "missing.urdf", (0, 0, 1))
        broken = tmp_path / "broken.urdf"
        broken.write_text("<robot name='x'><link name='a'>")
        with pytest.raises(RuntimeError, match="broken.urdf"):
            sim.add_object(broken, (0, 0, 1))
        with pytest.raises(ValueError, match="unit quaternion"):
            sim.add_object(box_urdf, (0, 0, 1), (0, 0, 0, 0))
        handle = sim.add_object(box_urdf, (1.0, 1.0, 0.05), name="crate")
        assert isinstance(handle, ObjectHandle) and handle.name == "crate" and sim.objects() == [handle]
        sim.remove_object(handle)
        assert sim.objects() == []
    with pytest.raises(RuntimeError, match="closed"):
        sim.step()


def test_set_object_pose_moves_a_static_object(world, spec, kinematics, box_urdf):
    arm = SimArm(world, spec)
    handle = world.add_object(box_urdf, (2.0, 2.0, 0.05))
    world.step(12)
    assert arm.pad_state().normal_force_n == 0.0
    home = kinematics.forward_kinematics(spec.home_q)
    normal = -home.z_axis
    x = np.cross([0.0, 1.0, 0.0], normal)
    x /= np.linalg.norm(x)
    frame = np.stack([x, np.cross(normal, x), normal], axis=1)
    face = home.position_m - 0.001 * home.z_axis  # 1 mm into the pad
    world.set_object_pose(handle, face - BOX_SIZE[2] / 2 * normal, matrix_to_quat(frame))
    world.step(12)
    assert arm.pad_state().normal_force_n > 0.0
    world.remove_object(handle)
    with pytest.raises(ValueError, match="not in this world"):
        world.set_object_pose(handle, (0, 0, 0), (1, 0, 0, 0))


# ---- spring fingertip ---------------------------------------------------------------------------


def test_spring_joints_are_passive_and_return(world, spec):
    arm = SimArm(world, spec)
    world.step(120)
    rest = arm.spring_angles()
    assert np.abs(rest).max() < math.radians(1.5)  # only gravity sag
    # a torque about the spring_x axis deflects spring_x by about tau / k
    torque = 0.004
    axis = arm.link_state("spring_gimbal").rotation[:, 0]
    remove = world.add_pre_step_hook(lambda t: arm.apply_pad_wrench(torque_nm=torque * axis))
    world.step(240)
    deflection = arm.spring_angles() - rest
    assert deflection[0] == pytest.approx(torque / spec.spring_stiffness_nm_per_rad, rel=0.1)
    assert abs(deflection[1]) < 0.2 * abs(deflection[0])
    remove()
    world.step(240)
    assert np.abs(arm.spring_angles() - rest).max() < math.radians(0.5)
    # without the spring torque nothing holds the module: the same push leaves it deflected
    arm.set_spring(0.0, 0.0)
    remove = world.add_pre_step_hook(lambda t: arm.apply_pad_wrench(torque_nm=torque * axis))
    world.step(60)
    remove()
    world.step(240)
    assert abs(arm.spring_angles()[0] - rest[0]) > math.radians(20)


def test_unstable_spring_settings_are_refused(world, spec):
    bodies = pybullet.getNumBodies(physicsClientId=world.client)
    with pytest.raises(ValueError, match="too stiff for time step"):
        SimArm(world, spec, spring_stiffness_nm_per_rad=2.0)
    with pytest.raises(ValueError, match="must be >= 0"):
        SimArm(world, spec, spring_damping_nms_per_rad=-1.0)
    assert pybullet.getNumBodies(physicsClientId=world.client) == bodies  # refused arms leave nothing
    # the bound scales with dt^2: the same spring is fine with a ten times smaller step
    with SimWorld(time_step_s=world.time_step_s / 10, table=None) as fine:
        assert SimArm(fine, spec, spring_stiffness_nm_per_rad=2.0).spring_stiffness_nm_per_rad == 2.0
    arm = SimArm(world, spec)
    arm.remove()
    assert pybullet.getNumBodies(physicsClientId=world.client) == bodies


@pytest.mark.parametrize("tilt_deg", [20.0])
def test_pad_self_aligns_with_a_tilted_surface(world, spec, kinematics, box_urdf, tilt_deg):
    arm = SimArm(world, spec)
    home = kinematics.forward_kinematics(spec.home_q)
    normal, face_centre = _place_tilted_box(world, box_urdf, home, math.radians(tilt_deg))
    world.step(24)
    free = arm.pad_state()
    assert isinstance(free, PadState) and free.normal_force_n == 0.0 and free.contact_normal is None
    body_axis = quat_to_matrix(free.quat_wxyz)[:, 2]
    assert math.degrees(angle_between_vectors(body_axis, -normal)) == pytest.approx(tilt_deg, abs=1.5)

    result = arm.guarded_move(_approach_path(kinematics, home, 0.04), lambda: arm.pad_state().normal_force_n > 2.0,
                              speed_rad_s=0.05)
    assert result.stopped
    world.step(120)
    pressed = arm.pad_state()
    assert pressed.normal_force_n > 0.5
    assert arm.pad_normal_force_n() == pressed.normal_force_n  # the force-only query (every physics step)
    body_axis = quat_to_matrix(pressed.quat_wxyz)[:, 2]
    assert math.degrees(angle_between_vectors(body_axis, -normal)) < 3.0
    assert math.degrees(angle_between_vectors(pressed.contact_normal, normal)) < 0.5
    assert abs(np.dot(pressed.contact_point_m - face_centre, normal)) < 1e-3  # on the face plane
    touching = [c for c in arm.contacts() if c.other == "tilted box"]
    assert touching and {c.link for c in touching} == {"pad"} and touching[0].object_key == 0

    arm.move_joints(spec.home_q, speed_rad_s=0.3)
    world.step(24)
    assert arm.pad_state().normal_force_n == 0.0 and arm.pad_state().contact_point_m is None


# ---- motion -------------------------------------------------------------------------------------


def test_guarded_move_stops_when_the_predicate_fires_and_holds(world, spec):
    arm = SimArm(world, spec)
    target = spec.home_q + np.radians([10, -10, 10, 10, -10, 0, 0])
    path = np.linspace(spec.home_q, target, 5)[1:]
    ticks = []

    def stop():
        ticks.append(world.time_s)
        return world.time_s >= 0.3

    assert isinstance(arm, Robot) and arm.dof == 7
    result = arm.guarded_move(path, stop, speed_rad_s=0.2)
    assert isinstance(result, GuardedMoveResult) and result.stopped and result.waypoint_index < len(path) - 1
    tick = arm.control_steps * world.time_step_s
    assert np.allclose(np.diff(ticks), tick)  # called once per control tick
    assert ticks[-1] == pytest.approx(0.3, abs=tick)
    moved = np.abs(result.q - spec.home_q).max()
    assert 0.2 * 0.3 * 0.5 < moved < 0.2 * 0.3 * 1.5  # the fastest joint ran at about 0.2 rad/s
    world.step(240)
    assert np.abs(arm.true_joint_positions() - result.q).max() < 2e-3  # held where it stopped


def test_guarded_move_runs_the_whole_path_when_never_stopped(world, spec):
    arm = SimArm(world, spec)
    target = spec.home_q + np.radians([5, 5, -5, 5, 5, 5, -5])
    t0 = arm.time_s()
    result = arm.guarded_move(target[None], lambda: False, speed_rad_s=0.5)
    assert not result.stopped and result.waypoint_index == 0
    assert np.abs(result.q - target).max() < 2e-3
    assert arm.time_s() - t0 >= math.radians(5) / 0.5
    # a request beyond the joints' velocity limits is slowed down to them
    t0 = arm.time_s()
    arm.move_joints(spec.home_q, speed_rad_s=100.0)
    assert arm.time_s() - t0 >= np.max(np.abs(target - spec.home_q) / arm.velocity_limit_rad_s)


def test_move_rejects_bad_targets_and_reports_blocked_moves(world, spec, box_urdf, kinematics):
    arm = SimArm(world, spec)
    with pytest.raises(ValueError, match="shoulder_1 = 90.00 deg not in"):
        arm.move_joints(np.radians([90, 30, 15, -90, 35, 5, 40]))
    with pytest.raises(ValueError, match=r"path must have shape \(k, 7\)"):
        arm.guarded_move(np.zeros((3, 6)), lambda: False)
    with pytest.raises(ValueError, match="speed_rad_s must be positive"):
        arm.move_joints(spec.home_q, speed_rad_s=0.0)
    # a box right in front of the pad blocks a move through it: a protective stop, and the arm
    # holds there instead of pressing on towards a target 25 mm inside the box
    home = kinematics.forward_kinematics(spec.home_q)
    _place_tilted_box(world, box_urdf, home, 0.0, gap_m=0.005)
    with pytest.raises(MoveNotReachedError, match=r"protective stop: pad pressed \d+ N on tilted box"):
        arm.move_joints(_approach_path(kinematics, home, 0.03)[-1], speed_rad_s=0.2)
    world.step(480)  # 2 s
    pressing = sum(c.normal_force_n for c in arm.contacts() if c.other == "tilted box")
    assert pressing < 2 * PROTECTIVE_STOP_N


def test_reset_teleports_and_holds(world, spec):
    arm = SimArm(world, spec)
    target = spec.home_q + np.radians([-10, 10, 0, 10, 0, 5, 5])
    arm.reset_joint_positions(target)
    assert np.allclose(arm.true_joint_positions(), target) and world.time_s == 0.0
    world.step(240)
    assert np.abs(arm.true_joint_positions() - target).max() < 1e-3
    with pytest.raises(ValueError, match="outside the joint limits"):
        arm.reset_joint_positions(spec.home_q + 10.0)


def test_encoder_model_adds_noise_and_quantisation(world, spec):
    resolution = math.radians(0.1)
    arm = SimArm(world, spec, encoder=EncoderModel(noise_std_rad=1e-3, resolution_rad=resolution, seed=3))
    readings = np.array([arm.joint_positions() for _ in range(400)])
    steps = readings / resolution
    assert np.allclose(steps, np.round(steps), atol=1e-9)
    error = readings - arm.true_joint_positions()
    assert np.std(error) == pytest.approx(math.sqrt(1e-3**2 + resolution**2 / 12), rel=0.15)
    exact = SimArm(world, spec, q_init_rad=spec.home_q)
    assert np.array_equal(exact.joint_positions(), exact.true_joint_positions())
    with pytest.raises(ValueError, match="must be >= 0"):
        EncoderModel(noise_std_rad=-1.0)


def test_pad_state_velocity_matches_position_differences(world, spec):
    """PyBullet integrates semi-implicitly: x[n] - x[n-1] = dt * v[n] up to joint-to-Cartesian curvature."""
    arm = SimArm(world, spec)
    target = spec.home_q + np.radians([8, 0, 0, 8, 0, 0, 0])
    states = []
    world.add_step_listener(lambda t: states.append(arm.pad_state()))
    arm.guarded_move(target[None], lambda: False, speed_rad_s=0.3)
    positions = np.array([s.position_m for s in states])
    velocities = np.array([s.lin_vel_mps for s in states])
    backward = np.diff(positions, axis=0) / world.time_step_s
    moving = np.linalg.norm(backward, axis=1) > 0.02
    assert moving.sum() > 50
    assert np.abs(backward[moving] - velocities[1:][moving]).max() < 0.01 * np.abs(velocities).max()
    rotations = quat_to_matrix(np.array([s.quat_wxyz for s in states]))
    relative = rotations[1:] @ np.swapaxes(rotations[:-1], 1, 2)  # small rotation per step, world frame
    turned = np.stack([relative[:, 2, 1] - relative[:, 1, 2], relative[:, 0, 2] - relative[:, 2, 0],
                       relative[:, 1, 0] - relative[:, 0, 1]], axis=1) / (2 * world.time_step_s)
    angular = np.array([s.ang_vel_radps for s in states])[1:]
    assert np.abs(turned - angular).max() < 0.01 * np.abs(angular).max() + 1e-3
    times = np.array([s.t_s for s in states])
    assert np.allclose(np.diff(times), world.time_step_s)


def _wall_beside_the_pad(world, box_urdf, home, gap_m=0.004):
    """A box wall parallel to the pad's face axis, ``gap_m`` beside the pad's +x side wall."""
    side = home.rotation[:, 0]
    frame = np.stack([home.rotation[:, 2], home.rotation[:, 1], side], axis=1)  # box z (0.1 m) across
    centre = home.position_m + (0.009 + gap_m + BOX_SIZE[2] / 2) * side - 0.02 * home.z_axis
    world.add_object(box_urdf, centre, matrix_to_quat(frame), name="wall")
    return side


@pytest.mark.parametrize("gain", [0.0, 0.1])
def test_the_barometer_feels_little_of_a_push_on_the_pads_side(world, spec, kinematics, box_urdf, gain):
    """A face-on press is felt whole; a sideways push on the pad's side wall only by
    ``pad_side_pressure_gain``, against the raw contact forces PyBullet reports."""
    import dataclasses
    arm = SimArm(world, dataclasses.replace(spec, pad_side_pressure_gain=gain))
    home = kinematics.forward_kinematics(spec.home_q)
    side = _wall_beside_the_pad(world, box_urdf, home)
    n = 9
    points = home.position_m + np.linspace(0.0, 0.008, n)[:, None] * side  # 4 mm into the wall
    path = solve_pad_ik(kinematics, points, np.tile(home.z_axis, (n, 1)), q_seed=spec.home_q)
    assert path.success.all()
    arm.guarded_move(path.q_rad, stop=lambda: False, speed_rad_s=0.05)
    world.step(60)
    raw = [c for c in arm.pad_contacts() if c.normal_force_n > 0.0]
    total = sum(c.normal_force_n for c in raw)
    assert total > 0.5, "the pad's side must be loaded"
    felt = arm.pad_state().normal_force_n
    assert felt == arm.pad_normal_force_n()
    assert felt <= gain * total + 0.05 * total  # normals within ~3 deg of the wall's
    assert felt >= gain * total * 0.95


def test_a_face_on_press_is_felt_whole(world, spec, kinematics, box_urdf):
    arm = SimArm(world, spec)
    home = kinematics.forward_kinematics(spec.home_q)
    _place_tilted_box(world, box_urdf, home, 0.0)
    arm.guarded_move(_approach_path(kinematics, home, 0.04), lambda: arm.pad_state().normal_force_n > 2.0,
                     speed_rad_s=0.05)
    world.step(60)
    total = sum(c.normal_force_n for c in arm.pad_contacts() if c.normal_force_n > 0.0)
    assert total > 1.0
    assert arm.pad_state().normal_force_n == pytest.approx(total, rel=0.01)
