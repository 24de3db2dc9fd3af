"""The planner rejects a standoff that would put the hand on a point the pad has touched
(``PlannerConfig.hand_clearance_m``): such a touch used to be lost, every transfer to the standoff
blocked by the hand meeting the object (mug and ring handles, issue 11)."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import robots
from explorer.planner import ApproachPlanner, PlannerConfig
from explorer.positioner import SimulatedStand, turntable_poses
from explorer.touch import ObjectPrior, Touch
from robots.ik import PadIK
from robots.kinematics import ArmKinematics
from robots.link_shapes import ArmShapes

HALF_M = 0.05


@pytest.fixture(scope="module", params=["armar3", "armar6"])
def planner(request):
    kin = ArmKinematics(robots.load(request.param))
    stand = SimulatedStand(lambda position, quaternion: None, kin.spec.workspace_center_m, turntable_poses(12, 4))
    return ApproachPlanner(kin, PadIK(kin), stand, ObjectPrior(np.zeros(3), np.full(3, HALF_M)), PlannerConfig())


def _hand(planner) -> ArmShapes:
    names = list(planner.kin.link_names)
    return ArmShapes(planner.kin, names[1:names.index(planner.kin.spec.tool_link)])


def test_a_touched_point_at_the_standoff_hand_moves_or_rejects_the_plan(planner):
    touch = Touch(np.array([-HALF_M, 0.0, 0.0]), np.array([1.0, 0.0, 0.0]))
    free = planner.plan(touch, tilted=False)
    assert free is not None, "premise: the touch is reachable"
    hand = _hand(planner)
    names = list(planner.kin.link_names)
    wrist = planner.kin.pose_of_one(free.standoff_q, link=names[names.index(planner.kin.spec.tool_link) - 1])[0]
    assert hand.signed_distance_m(free.standoff_q[None], wrist[None])[0] < 0.0, "premise: the point is in the wrist"
    R, t = planner.positioner.object_to_world(free.stand)
    on_hand = (wrist[None] - t) @ R  # object frame

    far = np.array([[0.0, 0.0, -1.0]])  # a touched point a metre away changes nothing
    again = planner.plan(touch, tilted=False, touched_m=far)
    assert again is not None and again.stand == free.stand
    np.testing.assert_allclose(again.path_q, free.path_q)

    moved = planner.plan(touch, tilted=False, touched_m=on_hand)
    if moved is not None:  # another stand pose, with the hand clear of the point
        R, t = planner.positioner.object_to_world(moved.stand)
        gap = hand.signed_distance_m(moved.standoff_q[None], on_hand @ R.T + t)[0]
        assert gap >= planner.config.hand_clearance_m
        assert moved.stand != free.stand

    off = dataclasses.replace(planner.config, hand_clearance_m=None)
    unchecked = ApproachPlanner(planner.kin, planner.ik, planner.positioner, planner.prior, off)
    same = unchecked.plan(touch, tilted=False, touched_m=on_hand)
    assert same is not None and same.stand == free.stand
    np.testing.assert_allclose(same.path_q, free.path_q)
