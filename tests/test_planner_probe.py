"""The planner's probe past the target: how deep a touch may go before it counts as a miss."""
from __future__ import annotations

import copy
import dataclasses

import numpy as np
import pytest

import robots
from explorer.planner import ApproachPlanner, PlannerConfig
from explorer.positioner import FixedStand
from explorer.touch import ObjectPrior, Touch
from robots.ik import PadIK
from robots.kinematics import ArmKinematics

HALF_M = 0.05


@pytest.fixture(scope="module")
def kinematics():
    return ArmKinematics(robots.load("armar3"))


@pytest.fixture(scope="module")
def planner(kinematics):
    centre = np.asarray(kinematics.spec.workspace_center_m, float)
    return ApproachPlanner(kinematics, PadIK(kinematics), FixedStand(centre), ObjectPrior(np.zeros(3), np.full(3, HALF_M)),
                           PlannerConfig())


class CutIK:
    """The real IK, but every waypoint more than ``beyond_m`` past ``target_m`` along ``approach`` fails."""

    def __init__(self, ik, target_world_m, approach, beyond_m):
        self.ik, self.target, self.approach, self.beyond = ik, target_world_m, approach, beyond_m

    def solve(self, positions_m, approach_dirs, q_seed=None):
        result = self.ik.solve(positions_m, approach_dirs, q_seed)
        past = (np.asarray(positions_m) - self.target) @ self.approach > self.beyond + 1e-9
        result.success[past] = False
        return result


def depth_reached(plan) -> float:
    """How far past the target (metres) the plan's last waypoint lies."""
    return float((plan.path_world_m[-1] - plan.target_world_m) @ plan.approach_world)


def test_prior_exit_is_the_distance_to_the_far_face_along_the_line(planner):
    assert planner.prior_exit_m(np.zeros(3), np.array([1.0, 0.0, 0.0])) == pytest.approx(HALF_M)
    diagonal = np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0)
    start = np.array([-0.02, 0.0, 0.01])
    # the line meets x = +HALF at 0.07 * sqrt(2) and y = +HALF at 0.05 * sqrt(2): the nearer face wins
    assert planner.prior_exit_m(start, diagonal) == pytest.approx(HALF_M * np.sqrt(2.0))
    assert planner.prior_exit_m(np.array([0.2, 0.0, 0.0]), np.array([1.0, 0.0, 0.0])) == 0.0


def test_a_touch_without_its_own_depth_probes_through_the_prior_box(planner):
    target, approach = np.array([-HALF_M, 0.0, 0.0]), np.array([1.0, 0.0, 0.0])
    plan = planner.plan(Touch(target, approach), tilted=False)
    assert plan is not None
    expected = min(planner.config.probe_depth_m, 2 * HALF_M) + planner.config.press_reserve_m
    assert depth_reached(plan) == pytest.approx(expected, abs=1e-9)
    assert depth_reached(plan) > planner.config.depth_m + planner.config.waypoint_spacing_m


def test_a_touch_with_its_own_depth_keeps_it(planner):
    target, approach = np.array([-HALF_M, 0.0, 0.0]), np.array([1.0, 0.0, 0.0])
    plan = planner.plan(Touch(target, approach, depth_m=0.02), tilted=False)
    assert plan is not None
    assert depth_reached(plan) == pytest.approx(0.02 + planner.config.press_reserve_m, abs=1e-9)


@pytest.mark.parametrize("depth_m", [0.0155, 0.02, 0.0299])
def test_the_line_ends_at_its_depth_and_reserve_not_a_spacing_short(depth_m):
    from explorer.planner import PlannerConfig, approach_line

    config = PlannerConfig()
    line = approach_line(np.zeros(3), np.array([0.0, 0.0, -1.0]), config, depth_m)
    offsets = -line[:, 2]
    assert offsets[0] == pytest.approx(-config.standoff_m)
    assert offsets[-1] == pytest.approx(depth_m + config.press_reserve_m)
    steps = np.diff(offsets)
    assert np.all(steps > 1e-6) and np.all(steps <= config.waypoint_spacing_m + 1e-9)


def test_the_probe_is_cut_where_the_arm_cannot_follow_but_not_shorter_than_the_depth(planner):
    target, approach = np.array([-HALF_M, 0.0, 0.0]), np.array([1.0, 0.0, 0.0])
    reference = planner.plan(Touch(target, approach), tilted=False)
    cut_at = 0.055
    clone = copy.copy(planner)
    clone.ik = CutIK(planner.ik, reference.target_world_m, reference.approach_world, cut_at)
    plan = clone.plan(Touch(target, approach), tilted=False)
    assert plan is not None
    assert depth_reached(plan) <= cut_at + 1e-9
    assert depth_reached(plan) >= cut_at - planner.config.waypoint_spacing_m
    np.testing.assert_allclose(plan.path_q, reference.path_q[:len(plan.path_q)])

    clone.ik = CutIK(planner.ik, reference.target_world_m, reference.approach_world, planner.config.depth_m / 2)
    assert clone.plan(Touch(target, approach), tilted=False) is None


def test_probe_depth_equal_to_the_depth_is_the_old_planner(kinematics, planner):
    old = ApproachPlanner(kinematics, planner.ik, planner.positioner, planner.prior,
                          dataclasses.replace(planner.config, probe_depth_m=planner.config.depth_m),
                          rest_q=planner.rest_q)
    plan = old.plan(Touch(np.array([-HALF_M, 0.0, 0.0]), np.array([1.0, 0.0, 0.0])), tilted=False)
    assert depth_reached(plan) == pytest.approx(planner.config.depth_m + planner.config.press_reserve_m, abs=1e-9)


def test_the_probe_depth_is_set_from_the_configuration_the_sweep_and_the_command_line(tmp_path):
    from explorer.backends import run_settings
    from explorer.config import load_config
    from explorer.sweep import SweepConfig, plan_runs

    config_file = tmp_path / "rig.toml"
    config_file.write_text('[robot]\nbackend = "sim"\n[sensor]\nbackend = "sim"\n[exploration]\nprobe_depth_m = 0.05\n')
    assert run_settings(load_config(config_file)).planner.probe_depth_m == 0.05
    config_file.write_text('[robot]\nbackend = "sim"\n[sensor]\nbackend = "sim"\n[exploration]\nprobe_depth_m = -1\n')
    with pytest.raises(ValueError, match="exploration.probe_depth_m"):
        load_config(config_file)
    sweep = SweepConfig(objects=("sphere",), strategies=("variance",), seeds=(0,), probe_depth_m=0.04)
    assert plan_runs(sweep)[0].settings(sweep).planner.probe_depth_m == 0.04
    with pytest.raises(ValueError, match="probe_depth_m"):
        SweepConfig(objects=("sphere",), strategies=("variance",), seeds=(0,), probe_depth_m=-0.01)


def test_the_retreat_path_backs_the_pad_straight_out_along_its_face_axis(planner, kinematics):
    plan = planner.plan(Touch(np.array([-HALF_M, 0.0, 0.0]), np.array([1.0, 0.0, 0.0])))
    q = plan.path_q[-1]
    start = kinematics.forward_kinematics(q)
    path = planner.retreat_path(q, distance_m=0.1)
    assert len(path) >= 5
    poses = [kinematics.forward_kinematics(p) for p in path]
    back = np.array([(start.position_m - p.position_m) @ start.z_axis for p in poses])
    off_line = np.array([np.linalg.norm(np.cross(p.position_m - start.position_m, start.z_axis)) for p in poses])
    assert np.all(np.diff(back) > 0.009) and back[-1] <= 0.1 + 1e-4  # 1 cm steps, away from the face
    assert off_line.max() < 1e-3
    assert min(float(p.z_axis @ start.z_axis) for p in poses) > np.cos(np.radians(2.0))


def test_the_retreat_path_stops_where_ik_fails(planner, kinematics):
    plan = planner.plan(Touch(np.array([-HALF_M, 0.0, 0.0]), np.array([1.0, 0.0, 0.0])))
    q = plan.path_q[-1]
    start = kinematics.forward_kinematics(q)
    # the IK fails 35 mm behind the pad: the path ends before it
    cut = copy.copy(planner)
    cut.ik = CutIK(planner.ik, start.position_m, -start.z_axis, 0.035)
    assert len(cut.retreat_path(q, distance_m=0.1)) == 3


def test_the_retreat_path_starts_from_joints_a_contact_pushed_past_their_limits(planner, kinematics):
    plan = planner.plan(Touch(np.array([-HALF_M, 0.0, 0.0]), np.array([1.0, 0.0, 0.0])))
    q = plan.path_q[-1].copy()
    q[-1] = kinematics.upper_rad[-1] + np.radians(1.0)  # on the mechanical stop, past the software limit
    path = planner.retreat_path(q, distance_m=0.05)
    assert len(path) >= 1
    assert np.all(path >= kinematics.lower_rad - 1e-9) and np.all(path <= kinematics.upper_rad + 1e-9)
