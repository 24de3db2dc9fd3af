"""The loop's recovery from a blocked free move (issue 12: the arm wedged on the table).

A blocked transfer leaves the hand pressed on the table or the object, joints pushed onto their
mechanical stops and every motor saturated; the old recovery, a move to rest at transfer speed
straight from there, wedged the hand harder and no joint moved again (the run ended). The loop
now backs out first (:func:`explorer.loop.back_out`).
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from explorer.loop import RECOVERY_LIMIT_CLEARANCE_RAD, RECOVERY_SPEED_RAD_S, ExplorationLoop, LoopConfig, back_out
from robots.interface import GuardedMoveResult

#: ARMAR-6's rest pose and a standoff whose straight transfer from rest sweeps the hand over the
#: coffee can (stand yaw 120 deg, upright) onto the table: the pose of the failed calibrated run.
REST_DEG = (-16.85, 6.15, 40.46, 31.75, -111.23, 36.99, 22.81, 1.17)
STANDOFF_DEG = (59.86, -10.01, -18.76, -108.76, -48.53, -85.08, 53.3, 60.0)


class _Events:
    def __init__(self):
        self.kinds: list[str] = []

    def event(self, kind, t_s, **fields):
        self.kinds.append(kind)


class _MovesRecorded:
    """A robot that goes wherever it is sent and records each guarded move's path and speed."""

    def __init__(self, q):
        self.q = np.asarray(q, float)
        self.moves: list[tuple[np.ndarray, float]] = []

    def joint_positions(self):
        return self.q.copy()

    def guarded_move(self, path, stop, speed_rad_s=0.2):
        path = np.asarray(path, float)
        self.moves.append((path, speed_rad_s))
        self.q = path[-1].copy()
        return GuardedMoveResult(stopped=False, q=self.q.copy(), waypoint_index=len(path) - 1)


def test_back_out_takes_joints_off_their_stops_then_reverses_slowly():
    lower, upper = np.radians([-20.0, -60.0, -45.0]), np.radians([130.0, 60.0, 60.0])
    pushed = np.radians([-21.0, 61.0, 10.0])  # two joints beyond their software limits, as contact leaves them
    start = np.radians([40.0, 20.0, 1.0])
    robot = _MovesRecorded(pushed)
    back_out(robot, start, lower, upper)
    (first, speed1), (second, speed2) = robot.moves
    np.testing.assert_allclose(first[-1], [lower[0] + RECOVERY_LIMIT_CLEARANCE_RAD,
                                           upper[1] - RECOVERY_LIMIT_CLEARANCE_RAD, pushed[2]])
    np.testing.assert_allclose(second[-1], start)
    assert speed1 == speed2 == RECOVERY_SPEED_RAD_S


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_a_transfer_blocked_on_the_table_ends_at_rest_or_its_target_not_wedged():
    from explorer.positioner import StandPose
    from explorer.rig import Rig, object_prior
    from explorer.simulation import build_scene
    from fakes import FakePlanner, ScriptedStrategy
    from reconstruction.gpis import GPIS

    rest, standoff = np.radians(REST_DEG), np.radians(STANDOFF_DEG)
    with build_scene("coffee_can", "armar6", seed=0, profile="hardware-like") as scene:
        rig = Rig(scene.arm, scene.sensor, scene.kinematics, scene.stand,
                  object_prior(scene.object_model.mesh), None, {}, scene.pad)
        planner = FakePlanner(scene.stand)
        planner.rest_q = rest
        planner.retreat_path = lambda q, **kwargs: np.empty((0, len(q)))  # direct and via rest only
        events = _Events()
        loop = ExplorationLoop(rig, planner, ScriptedStrategy([]), GPIS(bounds=rig.prior.bounds()),
                               LoopConfig(), events)
        scene.stand.move_to(StandPose(np.radians(120.0), 0.0))
        scene.arm.reset_joint_positions(rest)
        scene.arm.hold(0.2)
        reached = loop._transfer(standoff)  # raised MoveNotReachedError (wedged at rest's 145 deg) before
        q = scene.arm.servo_positions()
        goal = standoff if reached else rest
        assert np.max(np.abs(q - goal)) < 2.5e-3
        assert reached or events.kinds.count("transfer_blocked") == 2
        # The simulator names what the hand met; metrics.json counts it.
        assert loop.blocked_moves["transfer"] == events.kinds.count("transfer_blocked")
        assert sum(loop.blocked_on.values()) == sum(loop.blocked_moves.values())
        assert set(loop.blocked_on) <= {"table", scene.object_model.name}, loop.blocked_on
        table = [c for c in scene.arm.contacts() if c.other == "table" and c.normal_force_n > 1.0]
        assert not table, f"still pressed on the table: {table}"


def _blocked_on_the_way_to_rest(blocked_moves: int):
    """A fake rig whose first ``blocked_moves`` moves to rest meet the object (protective stops);
    (world, rig with that robot, planner). The robot records each move's kind, start or path, speed."""
    from fakes import FakePlanner, FakeRobot, sphere_rig
    from robots.interface import MoveNotReachedError

    class BlockedOnTheWayToRest(FakeRobot):
        def __init__(self, world, rest):
            super().__init__(world)
            self.rest, self.calls, self.blocked = rest, [], 0

        def move_joints(self, q, speed_rad_s=1.0):
            self.calls.append(("move", self.joint_positions(), speed_rad_s))
            if np.allclose(q, self.rest) and self.blocked < blocked_moves:
                self.blocked += 1
                raise MoveNotReachedError("protective stop: wrist pressed 80 N on the object")
            super().move_joints(q, speed_rad_s)

        def guarded_move(self, path, stop, speed_rad_s=0.2):
            self.calls.append(("guarded", np.asarray(path, float), speed_rad_s))
            return super().guarded_move(path, stop, speed_rad_s)

    world, rig = sphere_rig()
    planner = FakePlanner(rig.positioner)
    robot = BlockedOnTheWayToRest(world, planner.rest_q)
    return world, dataclasses.replace(rig, robot=robot), planner


def test_a_blocked_move_to_rest_backs_the_pad_out_along_its_axis_before_trying_again():
    from fakes import ScriptedStrategy
    from reconstruction.gpis import GPIS

    world, rig, planner = _blocked_on_the_way_to_rest(1)
    robot = rig.robot
    events = _Events()
    loop = ExplorationLoop(rig, planner, ScriptedStrategy([]), GPIS(bounds=rig.prior.bounds()), LoopConfig(), events)
    near = world.centre_m + np.array([world.radius_m + 0.005, 0.0, 0.0])  # 5 mm off the sphere
    world.pad_m = near.copy()
    loop._to_rest()
    assert events.kinds == ["rest_blocked"]
    assert loop.blocked_moves_summary() == {"rest": 1, "on": {"unknown": 1}}  # the fake does not say what it met
    np.testing.assert_allclose(robot.joint_positions(), planner.rest_q)
    retreats = [c for c in robot.calls if c[0] == "guarded" and len(c[1]) > 1]
    assert len(retreats) == 1, "one straight retreat"
    path, speed = retreats[0][1], retreats[0][2]
    np.testing.assert_allclose(path, planner.retreat_path(near))
    assert speed == RECOVERY_SPEED_RAD_S
    kinds = [c[0] for c in robot.calls]
    assert kinds.index("guarded") < len(kinds) - 1 and kinds[-1] == "move"  # retreat, then rest
    assert robot.calls[-1][2] == RECOVERY_SPEED_RAD_S


def test_a_move_to_rest_blocked_twice_ends_with_a_slow_guarded_move_there():
    from fakes import ScriptedStrategy
    from reconstruction.gpis import GPIS

    world, rig, planner = _blocked_on_the_way_to_rest(2)
    robot = rig.robot
    events = _Events()
    loop = ExplorationLoop(rig, planner, ScriptedStrategy([]), GPIS(bounds=rig.prior.bounds()), LoopConfig(), events)
    world.pad_m = world.centre_m + np.array([world.radius_m + 0.005, 0.0, 0.0])
    loop._to_rest()
    assert events.kinds == ["rest_blocked", "rest_forced"]
    np.testing.assert_allclose(robot.joint_positions(), planner.rest_q)
    assert [c[0] for c in robot.calls[-2:]] == ["guarded", "move"]  # the forced move, then the check it is there


class _OnlyTheWayItCame:
    """Wraps a fake robot: a move to rest from within ``near_m`` of ``centre`` is blocked unless it
    starts at ``clear_from`` (the arm came to the standoff around the object; a straight move back
    from there meets it), and the moves listed in ``blocked_legs`` ((from, to) pairs) are blocked too."""

    def __init__(self, robot, rest, centre, near_m, clear_from, blocked_legs=()):
        self.robot, self.rest, self.clear_from = robot, np.asarray(rest, float), np.asarray(clear_from, float)
        self.centre, self.near_m = np.asarray(centre, float), near_m
        self.blocked_legs = [(np.asarray(a, float), np.asarray(b, float)) for a, b in blocked_legs]
        self.moves: list[np.ndarray] = []

    def __getattr__(self, name):
        return getattr(self.robot, name)

    def move_joints(self, q, speed_rad_s=1.0):
        from robots.interface import MoveNotReachedError

        here, q = self.robot.joint_positions(), np.asarray(q, float)
        self.moves.append(q.copy())
        blocked = (np.allclose(q, self.rest) and np.linalg.norm(here - self.centre) < self.near_m
                   and not np.allclose(here, self.clear_from, atol=1e-6))
        blocked |= any(np.allclose(here, a, atol=1e-6) and np.allclose(q, b) for a, b in self.blocked_legs)
        if blocked:
            raise MoveNotReachedError("protective stop: wrist pressed 90 N on the object")
        self.robot.move_joints(q, speed_rad_s)


def _came_around_the_sphere(way_back_blocked: bool = False):
    """A loop whose arm went rest -> above the sphere -> a standoff beside it by free moves;
    (world, loop, robot, rest, above, standoff, events). ``way_back_blocked``: the move from the
    standoff back above the sphere meets it too."""
    from fakes import FakePlanner, ScriptedStrategy, sphere_rig
    from reconstruction.gpis import GPIS

    world, rig = sphere_rig()
    planner = FakePlanner(rig.positioner)
    rest = planner.rest_q
    above = world.centre_m + np.array([0.0, 0.0, world.radius_m + 0.05])
    standoff = world.centre_m + np.array([world.radius_m + 0.03, 0.0, 0.0])
    robot = _OnlyTheWayItCame(rig.robot, rest, world.centre_m, 0.1, clear_from=above,
                              blocked_legs=[(standoff, above)] if way_back_blocked else ())
    rig = dataclasses.replace(rig, robot=robot)
    events = _Events()
    loop = ExplorationLoop(rig, planner, ScriptedStrategy([]), GPIS(bounds=rig.prior.bounds()), LoopConfig(),
                           events)
    world.pad_m = rest.copy()
    loop._free_move(above)
    loop._free_move(standoff)
    return world, loop, robot, rest, above, standoff, events


def test_a_blocked_move_to_rest_goes_back_the_way_the_arm_came():
    world, loop, robot, rest, above, standoff, events = _came_around_the_sphere()
    robot.moves.clear()
    loop._to_rest()
    assert events.kinds == ["rest_blocked", "retrace"]
    np.testing.assert_allclose(robot.joint_positions(), rest)
    # the straight move (blocked), then the trail in reverse: the standoff (where the arm stands),
    # above the sphere, rest
    assert len(robot.moves) == 4
    for move, q in zip(robot.moves[1:], (standoff, above, rest)):
        np.testing.assert_allclose(move, q)
    # at rest the trail starts again there
    assert len(loop._trail) == 1 and np.allclose(loop._trail[0], rest)


def test_a_retrace_blocked_too_falls_back_to_the_retreat_along_the_pad_axis():
    world, loop, robot, rest, above, standoff, events = _came_around_the_sphere(way_back_blocked=True)
    loop._to_rest()
    assert events.kinds == ["rest_blocked", "retrace", "retrace_blocked"]
    assert loop.blocked_moves_summary()["retrace"] == 1
    np.testing.assert_allclose(robot.joint_positions(), rest)


def test_the_retract_goes_back_along_the_approach_line_never_deeper():
    """After a press the pad goes back through the approach waypoints it had passed, in reverse, to
    the standoff: a straight joint move from deep in a bowl swings the wrist into its rim."""
    from explorer.touch import Touch
    from fakes import FakePlanner, FakeRobot, ScriptedStrategy, sphere_rig
    from reconstruction.gpis import GPIS

    class Recorded(FakeRobot):
        def __init__(self, world):
            super().__init__(world)
            self.calls = []

        def move_joints(self, q, speed_rad_s=1.0):
            self.calls.append(("move", np.asarray(q, float).copy(), self.joint_positions()))
            super().move_joints(q, speed_rad_s)

        def guarded_move(self, path, stop, speed_rad_s=0.2):
            self.calls.append(("guarded", np.asarray(path, float).copy(), self.joint_positions()))
            return super().guarded_move(path, stop, speed_rad_s)

    world, rig = sphere_rig()
    robot = Recorded(world)
    rig = dataclasses.replace(rig, robot=robot)
    planner = FakePlanner(rig.positioner)
    touch = Touch(np.array([world.radius_m, 0.0, 0.0]), np.array([-1.0, 0.0, 0.0]), strategy="scripted")
    loop = ExplorationLoop(rig, planner, ScriptedStrategy([touch]), GPIS(bounds=rig.prior.bounds()), LoopConfig())
    record = loop.step()
    assert record.kind == "contact"
    plan = planner.plan(touch)
    along = lambda q: float((np.asarray(q) - plan.path_world_m[0]) @ plan.approach_world)  # noqa: E731
    kind, back, pressed_at = robot.calls[-2]
    assert kind == "guarded" and robot.calls[-1][0] == "move"
    np.testing.assert_allclose(robot.calls[-1][1], plan.standoff_q)
    k = len(back) - 1
    assert k >= 1, "the press went past at least one waypoint"
    np.testing.assert_allclose(back, plan.path_q[k::-1])  # the approach waypoints in reverse
    assert along(back[0]) <= along(pressed_at) < along(plan.path_q[k + 1])  # the last passed: never deeper
    np.testing.assert_allclose(robot.joint_positions(), plan.standoff_q)
