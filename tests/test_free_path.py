"""Free moves around the object's rough box (explorer/free_path.py, ApproachPlanner.transfer_path)."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from explorer.free_path import FreePathConfig, FreePathPlanner, box_signed_distance_m
from explorer.touch import ObjectPrior

IDENTITY = (np.eye(3), np.zeros(3))


def test_box_signed_distance_against_trimesh():
    import trimesh

    centre, half = np.array([0.1, -0.2, 0.3]), np.array([0.05, 0.02, 0.08])
    box = trimesh.creation.box(extents=2 * half, transform=trimesh.transformations.translation_matrix(centre))
    points = centre + np.random.default_rng(0).uniform(-0.15, 0.15, (500, 3))
    # trimesh: positive inside; ours: negative inside
    np.testing.assert_allclose(box_signed_distance_m(points, centre, half),
                               -trimesh.proximity.signed_distance(box, points), atol=1e-9)


class _PointArm:
    """A 'robot' whose configuration is the position of one sphere (radius 1 cm), to test the search."""

    radii_m = np.array([0.01])

    def centres_m(self, q):
        return np.atleast_2d(np.asarray(q, float))[:, None, :]


def _wall_planner(**config) -> FreePathPlanner:
    wall = ObjectPrior(np.zeros(3), np.array([0.05, 0.5, 0.5]))  # a slab across x = 0
    return FreePathPlanner(_PointArm(), wall, np.full(3, -1.0), np.full(3, 1.0),
                           FreePathConfig(clearance_m=0.02, check_step_rad=0.005, extend_rad=0.2, **config))


def _dense_clearance(planner, start, path, step=1e-3):
    """Smallest clearance along ``start`` then ``path``, resampled every ``step`` (finer than the planner)."""
    points = np.vstack([start[None], path])
    worst = np.inf
    for a, b in zip(points[:-1], points[1:]):
        n = max(2, int(np.ceil(np.max(np.abs(b - a)) / step)) + 1)
        s = np.linspace(0, 1, n)[:, None]
        worst = min(worst, float(planner.clearance_m(a + s * (b - a), IDENTITY).min()))
    return worst


def test_a_clear_straight_line_is_kept():
    planner = _wall_planner()
    start, goal = np.array([0.2, 0.0, 0.0]), np.array([0.3, 0.2, -0.1])
    np.testing.assert_array_equal(planner.plan(start, goal, IDENTITY), goal[None])


def test_a_path_through_the_box_goes_around_it_clear_all_the_way():
    planner = _wall_planner()
    start, goal = np.array([-0.3, 0.0, 0.0]), np.array([0.3, 0.1, 0.0])
    assert not planner.segment_clear(start, goal, IDENTITY)
    path = planner.plan(start, goal, IDENTITY)
    assert path is not None and len(path) >= 2
    np.testing.assert_array_equal(path[-1], goal)
    # resampled finer than the planner's check step: the margin lost between checks is at most
    # half a check step (0.0025) of the 2 cm clearance
    assert _dense_clearance(planner, start, path) >= 0.02 - 0.0025
    again = planner.plan(start, goal, IDENTITY)
    np.testing.assert_array_equal(path, again)  # seeded: the same plan twice


def test_no_path_when_an_end_is_inside_or_no_way_around():
    planner = _wall_planner()
    assert planner.plan(np.array([0.0, 0.0, 0.0]), np.array([0.3, 0.0, 0.0]), IDENTITY) is None
    sealed = FreePathPlanner(_PointArm(), ObjectPrior(np.zeros(3), np.array([0.05, 5.0, 5.0])), np.full(3, -1.0),
                             np.full(3, 1.0), FreePathConfig(max_samples=50))
    assert sealed.plan(np.array([-0.3, 0, 0]), np.array([0.3, 0, 0]), IDENTITY) is None


def test_the_box_is_taken_in_the_object_frame_of_the_stand():
    planner = _wall_planner()
    turned = (np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]), np.array([0.0, 0.0, 0.0]))
    start, goal = np.array([-0.3, 0.0, 0.0]), np.array([0.3, 0.0, 0.0])
    # turned by 90 deg about z the wall lies across y = 0: the line along x crosses it only at the centre
    assert not planner.segment_clear(start, goal, IDENTITY)
    assert not planner.segment_clear(start, goal, turned)
    assert not planner.segment_clear(start + [0, 0.3, 0], goal + [0, 0.3, 0], IDENTITY)
    assert planner.segment_clear(np.array([0.3, -0.3, 0.0]), np.array([0.3, 0.3, 0.0]), IDENTITY)
    assert not planner.segment_clear(np.array([0.3, -0.3, 0.0]), np.array([0.3, 0.3, 0.0]), turned)


def test_a_fixed_obstacle_is_kept_clear_in_the_world_frame_whatever_the_stand():
    """A table (world frame) under a far-off prior box: the straight line through the table is
    refused and the plan goes around it; the stand's turn moves the prior box, not the table."""
    prior = ObjectPrior(np.array([0.0, 0.0, 0.8]), np.full(3, 0.05))  # far above the moves below
    table = (np.array([0.0, 0.0, -0.2]), np.array([0.05, 0.5, 0.2]))  # a slab across x = 0 below z = 0
    planner = FreePathPlanner(_PointArm(), prior, np.full(3, -1.0), np.full(3, 1.0),
                              FreePathConfig(clearance_m=0.02, check_step_rad=0.005, extend_rad=0.2),
                              obstacles=[table])
    start, goal = np.array([-0.3, 0.0, -0.2]), np.array([0.3, 0.1, -0.2])
    np.testing.assert_allclose(planner.clearance_m(np.array([[0.0, 0.0, 0.1]]), IDENTITY), [0.1 - 0.01])
    turned = (np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]), np.zeros(3))
    for stand in (IDENTITY, turned):
        assert not planner.segment_clear(start, goal, stand)
    path = planner.plan(start, goal, IDENTITY)
    assert path is not None and len(path) >= 2
    assert _dense_clearance(planner, start, path) >= 0.02 - 0.0025
    without = FreePathPlanner(_PointArm(), prior, np.full(3, -1.0), np.full(3, 1.0))
    assert without.segment_clear(start, goal, IDENTITY)


@pytest.mark.parametrize("field, value", [("clearance_m", -0.01), ("check_step_rad", 0.0), ("extend_rad", -1.0),
                                          ("max_samples", 0)])
def test_bad_config_is_named(field, value):
    with pytest.raises(ValueError, match=field):
        FreePathConfig(**{field: value})


def _visiting_loop(detour):
    """(world, robot recording each move_joints target, planner, event log, loop) on the fake rig."""
    from explorer.loop import ExplorationLoop, LoopConfig
    from fakes import FakePlanner, FakeRobot, ScriptedStrategy, sphere_rig
    from reconstruction.gpis import GPIS

    class Visits(FakeRobot):
        def __init__(self, world):
            super().__init__(world)
            self.visited = []

        def move_joints(self, q, speed_rad_s=1.0):
            super().move_joints(q, speed_rad_s)
            self.visited.append(np.asarray(q, float).copy())

    class Events:
        def __init__(self):
            self.kinds = []

        def event(self, kind, t_s, **fields):
            self.kinds.append((kind, fields))

    world, rig = sphere_rig()
    robot = Visits(world)
    rig = dataclasses.replace(rig, robot=robot)
    planner = FakePlanner(rig.positioner, detour=detour)
    events = Events()
    loop = ExplorationLoop(rig, planner, ScriptedStrategy([]), GPIS(bounds=rig.prior.bounds()), LoopConfig(), events)
    return world, robot, planner, events, loop


def test_with_no_clear_path_known_the_transfer_comes_in_along_the_approach_line_first():
    world, robot, planner, events, loop = _visiting_loop(detour=lambda q_from, q_to: None)
    world.pad_m = world.centre_m + np.array([0.1, 0.0, 0.0])
    goal = world.centre_m + np.array([0.0, 0.0, world.radius_m + 0.03])  # a standoff above the sphere
    assert loop._transfer(goal)
    far = planner.retreat_path(goal)[-1]  # the approach line's far end
    np.testing.assert_allclose(robot.visited[0], far)
    np.testing.assert_allclose(robot.visited[-1], goal)
    assert not [kind for kind, _ in events.kinds if kind == "transfer_blocked"]


def test_the_loop_follows_a_planned_route_and_records_it():
    """A transfer and a move to rest go through the waypoints ``transfer_path`` gives, in order."""
    above = np.array([0.0, 0.5, 1.2])  # the fake rig's sphere sits at (0, 0.5, 1.0)
    world, robot, planner, events, loop = _visiting_loop(detour=lambda q_from, q_to: above[None])
    world.pad_m = world.centre_m + np.array([0.1, 0.0, 0.0])
    goal = world.centre_m + np.array([-0.1, 0.0, 0.0])
    assert loop._transfer(goal)
    np.testing.assert_allclose(robot.visited[-2:], [above, goal])
    loop._to_rest()
    np.testing.assert_allclose(robot.visited[-2:], [above, planner.rest_q])
    assert [kind for kind, _ in events.kinds] == ["free_path", "free_path"]
    assert events.kinds[0][1]["waypoints"] == 2


#: ARMAR-6 standoffs for the cereal box at stand yaw 0: before its -x face, then above its top. The
#: straight joint path between them sweeps the hand through the box (protective stop at ~370 N).
FRONT_DEG = (-6.4, 4.69, 17.14, 35.94, -70.86, 47.91, 9.25, -38.99)
TOP_DEG = (35.27, -6.5, 78.99, 41.59, -111.93, 11.67, 25.53, 60.0)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_armar6_goes_around_the_cereal_box_where_the_straight_move_is_stopped():
    from explorer.planner import ApproachPlanner
    from explorer.rig import object_prior
    from explorer.simulation import build_scene
    from robots.ik import PadIK
    from robots.interface import MoveNotReachedError

    front, top = np.radians(FRONT_DEG), np.radians(TOP_DEG)
    with build_scene("cereal_box", "armar6", seed=0) as scene:
        planner = ApproachPlanner(scene.kinematics, PadIK(scene.kinematics), scene.stand,
                                  object_prior(scene.object_model.mesh))
        scene.arm.reset_joint_positions(front)
        scene.arm.hold(0.2)
        with pytest.raises(MoveNotReachedError, match="protective stop"):
            scene.arm.move_joints(top, 1.0)
        route = planner.transfer_path(front, top)
        assert len(route) >= 2
        np.testing.assert_array_equal(route[-1], top)
        scene.arm.reset_joint_positions(front)
        scene.arm.hold(0.2)
        for waypoint in route:
            scene.arm.move_joints(waypoint, 1.0)  # no protective stop on the way
        assert np.max(np.abs(scene.arm.servo_positions() - top)) < 2.5e-3
        assert not [c for c in scene.arm.contacts() if c.other == "cereal_box"]
        planner.config = dataclasses.replace(planner.config, free_move_clearance_m=None)
        np.testing.assert_array_equal(planner.transfer_path(front, top), top[None])  # the check off: straight


def test_an_arm_without_a_sphere_model_moves_straight_with_a_warning(monkeypatch):
    import robots.link_spheres
    from explorer.planner import ApproachPlanner
    from explorer.positioner import FixedStand
    from robots.ik import PadIK
    from robots.kinematics import ArmKinematics

    def refuse(urdf_path, links):
        raise ValueError("URDF arm.urdf, link 'hand': collision geometry <mesh> is not supported")

    monkeypatch.setattr(robots.link_spheres, "read_link_spheres", refuse)
    kin = ArmKinematics(robots.load("armar3"))
    prior = ObjectPrior(np.zeros(3), np.full(3, 0.05))
    planner = ApproachPlanner(kin, PadIK(kin), FixedStand(np.asarray(kin.spec.workspace_center_m)), prior)
    a, b = np.asarray(kin.spec.home_q_rad), np.asarray(kin.spec.home_q_rad) + 0.3
    with pytest.warns(UserWarning, match="<mesh>.*free moves go straight"):
        np.testing.assert_array_equal(planner.transfer_path(a, b), b[None])
    np.testing.assert_array_equal(planner.transfer_path(b, a), a[None])  # once: no second warning


def test_the_free_path_benchmark_refuses_a_bad_budget_with_one_line(capsys):
    from scripts.free_path_benchmark import main

    with pytest.raises(SystemExit) as stop:
        main(["--touches", "1"])
    assert stop.value.code == 2
    assert "--touches must be >= 2" in capsys.readouterr().err


@pytest.mark.parametrize("robot", ["armar3", "armar6"])
def test_the_rest_clearance_is_the_free_path_clearance_at_rest_and_turns_negative_for_a_crate(robot):
    """At one stand pose the rest clearance is the free-path planner's clearance of the rest pose (an
    independent sum over the same spheres); a hand-sized box clears the waiting arm by centimetres,
    a 50 cm crate's box reaches into it."""
    import robots
    from explorer.planner import ApproachPlanner
    from explorer.positioner import FixedStand, SimulatedStand, turntable_poses
    from robots.ik import PadIK
    from robots.kinematics import ArmKinematics

    kin = ArmKinematics(robots.load(robot))
    centre = np.asarray(kin.spec.workspace_center_m)
    small = ApproachPlanner(kin, PadIK(kin), FixedStand(centre), ObjectPrior(np.zeros(3), np.full(3, 0.05)))
    at_rest = small._free_path_planner().clearance_m(small.rest_q[None], small.positioner.object_to_world())[0]
    assert small.rest_clearance_m() == pytest.approx(at_rest, abs=1e-12)
    assert small.rest_clearance_m() > 0.02

    turning = SimulatedStand(lambda p, q: None, centre, turntable_poses())
    crate = ApproachPlanner(kin, PadIK(kin), turning, ObjectPrior(np.zeros(3), np.array([0.285, 0.175, 0.12])))
    assert crate.rest_clearance_m() < 0
    assert crate.rest_clearance_m() <= min(
        crate._free_path_planner().clearance_m(crate.rest_q[None], turning.object_to_world(pose))[0]
        for pose in turning.poses) + 1e-12
