"""Contract suites: every implementation of an interface the loop depends on passes the same tests.

One test class per interface, parametrised over its implementations (as gpytorch's
``BaseKernelTestCase``): a new backend is added to the list and must pass. The interfaces are
``robots.interface.Robot``, ``sensor.interface.TactileSensor``, ``explorer.positioner.Positioner``
and ``explorer.strategies.TouchStrategy``.
"""
import contextlib

import numpy as np
import pytest

import robots
from explorer.positioner import FixedStand, SimulatedStand, StandPose, turntable_poses
from explorer.strategies import STRATEGIES, ExplorationState, TouchStrategy, make_strategy
from explorer.touch import ObjectPrior, Touch
from fakes import FakeRobot, FakeSensor, SphereWorld
from reconstruction.gpis import GPIS
from robots.interface import GuardedMoveResult, Robot
from sensor.interface import TactileSensor
from sensor.reading import Reading


# ---- robots -------------------------------------------------------------------------------------

@contextlib.contextmanager
def fake_robot():
    world = SphereWorld(np.zeros(3), 0.04)
    yield FakeRobot(world), world.pad_m + np.array([0.0, 0.0, 0.02]), 2e-3


@contextlib.contextmanager
def sim_arm():
    from robots.sim_arm import SimArm
    from robots.sim_world import SimWorld

    spec = robots.load("armar3")
    world = SimWorld(gui=False)
    try:
        arm = SimArm(world, spec)
        yield arm, np.asarray(spec.home_q, float) + 0.05, 0.02
    finally:
        world.close()


@contextlib.contextmanager
def serial_arm_on_emulators():
    from explorer.contact_world import VirtualSphere, emulated_rig

    spec = robots.load("armar3")
    far_away = np.asarray(spec.workspace_center_m, float) + np.array([0.0, 0.0, 5.0])
    rig = emulated_rig(spec, VirtualSphere(far_away, 0.05))
    with rig.arm, rig.sensor:
        yield rig.arm, np.asarray(spec.home_q, float) + 0.05, 0.02


ROBOTS = {"fake": fake_robot, "sim_arm": sim_arm, "serial_arm_emulated": serial_arm_on_emulators}


@pytest.fixture(params=sorted(ROBOTS))
def robot_case(request):
    """(robot, a reachable joint target near the start, joint tolerance rad)."""
    with ROBOTS[request.param]() as case:
        yield case


class TestRobotContract:
    def test_is_a_robot_with_finite_joint_positions(self, robot_case):
        robot, _, _ = robot_case
        assert isinstance(robot, Robot)
        q = robot.joint_positions()
        assert q.shape == (robot.dof,) and np.all(np.isfinite(q))

    def test_move_joints_reaches_the_target_and_time_advances(self, robot_case):
        robot, target, tolerance = robot_case
        t0 = robot.time_s()
        robot.move_joints(target, 1.0)
        assert np.max(np.abs(robot.joint_positions() - target)) < tolerance
        assert robot.time_s() > t0

    def test_guarded_move_stops_when_asked(self, robot_case):
        robot, target, _ = robot_case
        start = robot.joint_positions()
        result = robot.guarded_move(np.array([start + 0.5 * (target - start), target]), stop=lambda: True,
                                    speed_rad_s=0.2)
        assert isinstance(result, GuardedMoveResult)
        assert result.stopped and result.waypoint_index == 0
        assert np.max(np.abs(robot.joint_positions() - target)) > 0.5 * np.max(np.abs(target - start))

    def test_guarded_move_without_a_stop_follows_the_whole_path(self, robot_case):
        robot, target, tolerance = robot_case
        start = robot.joint_positions()
        path = np.array([start + 0.5 * (target - start), target])
        result = robot.guarded_move(path, stop=lambda: False, speed_rad_s=0.5)
        assert not result.stopped and result.waypoint_index == len(path) - 1
        assert np.max(np.abs(robot.joint_positions() - target)) < tolerance

    def test_hold_keeps_the_position_for_its_duration_or_until_stopped(self, robot_case):
        robot, _, tolerance = robot_case
        q0, t0 = robot.joint_positions(), robot.time_s()
        result = robot.hold(0.1)
        assert not result.stopped and robot.time_s() - t0 == pytest.approx(0.1, abs=0.03)
        assert np.max(np.abs(robot.joint_positions() - q0)) < tolerance
        t1 = robot.time_s()
        assert robot.hold(1.0, stop=lambda: True).stopped
        assert robot.time_s() - t1 < 0.1


# ---- sensors ------------------------------------------------------------------------------------

@contextlib.contextmanager
def fake_sensor():
    world = SphereWorld(np.zeros(3), 0.04)

    def advance(seconds):
        for _ in range(int(round(seconds / 0.01))):
            world.tick()

    yield FakeSensor(world), advance


@contextlib.contextmanager
def simulated_sensor():
    from common.pad_state import PadState
    from sensor.sim_sensor import SimulatedTactileSensor

    sensor = SimulatedTactileSensor(seed=0)
    clock = [0.0]

    def advance(seconds):
        for _ in range(int(round(seconds * 240))):
            clock[0] += 1.0 / 240
            sensor.on_step(PadState(clock[0], np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(3),
                                    np.zeros(3), 0.0))

    yield sensor, advance


@contextlib.contextmanager
def hardware_sensor_on_emulated_chips():
    from sensor.emulated_fingertip import PressScript, emulated_fingertip
    from sensor.emulators import FakeClock

    clock = FakeClock()
    yield emulated_fingertip(PressScript.regular(2), clock=clock.monotonic, sleep=clock.sleep), clock.advance


SENSORS = {"fake": fake_sensor, "simulated": simulated_sensor, "hardware_emulated": hardware_sensor_on_emulated_chips}


@pytest.fixture(params=sorted(SENSORS))
def sensor_case(request):
    """(sensor, advance(seconds))."""
    with SENSORS[request.param]() as case:
        yield case


def _check_readings(readings, after_s=-np.inf):
    times = [r.t_s for r in readings]
    assert times == sorted(times) and (not times or times[0] > after_s)
    for r in readings:
        assert isinstance(r, Reading) and np.isfinite(r.pressure_pa) and r.pressure_pa > 0
        assert np.linalg.norm(r.quat_wxyz) == pytest.approx(1.0, abs=1e-3)
        assert np.asarray(r.lin_acc_mps2).shape == (3,) and np.asarray(r.gravity_mps2).shape == (3,)


class TestTactileSensorContract:
    def test_is_a_tactile_sensor_and_a_context_manager(self, sensor_case):
        sensor, advance = sensor_case
        assert isinstance(sensor, TactileSensor)
        with sensor as opened:
            assert opened is sensor
            advance(0.1)
            _check_readings([sensor.read()])

    def test_drain_gives_each_reading_once_in_time_order(self, sensor_case):
        sensor, advance = sensor_case
        with sensor:
            advance(0.2)
            first = sensor.drain()
            assert first
            _check_readings(first)
            advance(0.2)
            second = sensor.drain()
            assert second
            _check_readings(second, after_s=first[-1].t_s)

    def test_open_and_close_are_idempotent(self, sensor_case):
        sensor, _ = sensor_case
        sensor.open()
        sensor.open()
        sensor.close()
        sensor.close()


# ---- positioners --------------------------------------------------------------------------------

CENTRE = np.array([0.1, 0.5, 0.9])

POSITIONERS = {
    "fixed": lambda: FixedStand(CENTRE),
    "simulated_stand": lambda: SimulatedStand(lambda p, q: None, CENTRE, turntable_poses(4, 2)),
}


@pytest.fixture(params=sorted(POSITIONERS))
def positioner(request):
    return POSITIONERS[request.param]()


class TestPositionerContract:
    def test_every_offered_pose_can_be_taken(self, positioner):
        assert positioner.poses and all(isinstance(p, StandPose) for p in positioner.poses)
        for pose in positioner.poses:
            positioner.move_to(pose)
            assert positioner.pose() == pose

    def test_to_object_inverts_to_world_and_keeps_the_frame_rigid(self, positioner):
        points = np.random.default_rng(0).normal(size=(5, 3))
        directions = points / np.linalg.norm(points, axis=1, keepdims=True)
        for pose in positioner.poses:
            positioner.move_to(pose)
            rotation, origin = positioner.object_to_world()
            np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-12)
            assert np.linalg.det(rotation) == pytest.approx(1.0)
            np.testing.assert_allclose(origin, positioner.centre_m)
            world, world_dirs = positioner.to_world(points, directions)
            back, back_dirs = positioner.to_object(world, world_dirs)
            np.testing.assert_allclose(back, points, atol=1e-12)
            np.testing.assert_allclose(back_dirs, directions, atol=1e-12)


# ---- strategies ---------------------------------------------------------------------------------

PRIOR = ObjectPrior(np.zeros(3), np.full(3, 0.05))


def _sphere_gpis(n: int = 8) -> GPIS:
    gpis = GPIS(bounds=PRIOR.bounds())
    directions = np.random.default_rng(1).normal(size=(n, 3))
    for d in directions / np.linalg.norm(directions, axis=1, keepdims=True):
        gpis.add(0.04 * d, d)
    return gpis


@pytest.fixture(params=sorted(STRATEGIES))
def strategy(request):
    return make_strategy(request.param, seed=0)


class TestTouchStrategyContract:
    def test_is_named_as_registered(self, strategy):
        assert isinstance(strategy, TouchStrategy)
        assert STRATEGIES[strategy.name] is type(strategy)

    @pytest.mark.parametrize("with_gpis", [False, True], ids=["before_contacts", "with_a_surface"])
    def test_proposes_at_most_count_touches_with_unit_directions(self, strategy, with_gpis):
        state = ExplorationState(PRIOR, _sphere_gpis() if with_gpis else None, touches=8 if with_gpis else 0)
        touches = strategy.propose(state, 4)
        assert 1 <= len(touches) <= 4
        lo, hi = PRIOR.bounds()
        for touch in touches:
            assert isinstance(touch, Touch) and touch.strategy in STRATEGIES  # variance starts uniform
            assert np.linalg.norm(touch.approach_dir) == pytest.approx(1.0)
            assert np.all(touch.target_m >= lo - 1e-9) and np.all(touch.target_m <= hi + 1e-9)
        strategy.accepted(touches[0])  # every strategy takes the loop's bookkeeping call

    def test_surface_variance_is_none_or_points_with_non_negative_variance(self, strategy):
        estimate = strategy.surface_variance(ExplorationState(PRIOR, _sphere_gpis(), touches=8))
        if estimate is None:
            return
        points, variance = estimate
        assert points.ndim == 2 and points.shape[1] == 3 and variance.shape == (len(points),)
        assert len(points) and np.all(variance >= 0)


def test_the_configuration_schema_offers_exactly_the_registered_strategies():
    from explorer.config import STRATEGY_NAMES

    assert sorted(STRATEGY_NAMES) == sorted(STRATEGIES)


def test_the_configuration_schema_and_the_sweep_default_to_the_planners_probe_depth():
    from explorer.config import ExplorationConfig
    from explorer.planner import PlannerConfig
    from explorer.sweep import SweepConfig

    assert ExplorationConfig().probe_depth_m == PlannerConfig().probe_depth_m
    assert SweepConfig(objects=("sphere",), strategies=("variance",), seeds=(0,)).probe_depth_m == \
        PlannerConfig().probe_depth_m
