"""Batched pad IK: reachable targets are reached, unreachable ones are reported as failures."""
from __future__ import annotations

import math

import numpy as np
import pytest
import torch

import robots
from robots.ik import IKOptions, PadIK, approach_frames, solve_pad_ik
from robots.kinematics import ArmKinematics
from common.rotations import angle_between_vectors


@pytest.fixture(scope="module", params=["armar3", "armar6"])
def kinematics(request):
    return ArmKinematics(robots.load(request.param))


def test_reachable_targets_are_reached_within_1mm_and_1deg(kinematics):
    rng = np.random.default_rng(7)
    q_true = rng.uniform(kinematics.lower_rad, kinematics.upper_rad, (40, kinematics.dof))
    target = kinematics.forward_kinematics(q_true)
    result = solve_pad_ik(kinematics, target.position_m, target.z_axis)
    assert result.success.mean() >= 0.95, f"{(~result.success).sum()} of 40 reachable targets failed"
    # check the solutions independently with FK
    reached = kinematics.forward_kinematics(result.q_rad)
    position_error = np.linalg.norm(reached.position_m - target.position_m, axis=1)
    angle_error = angle_between_vectors(reached.z_axis, target.z_axis)
    ok = result.success
    assert np.all(position_error[ok] <= 1e-3) and np.all(angle_error[ok] <= math.radians(1.0))
    assert np.allclose(position_error, result.position_error_m, atol=1e-9)
    assert np.allclose(angle_error, result.angle_error_rad, atol=1e-9)
    assert np.all(result.q_rad >= kinematics.lower_rad - 1e-12) and np.all(result.q_rad <= kinematics.upper_rad + 1e-12)


def test_unreachable_targets_are_failures_not_silent(kinematics):
    home = kinematics.forward_kinematics(kinematics.spec.home_q)
    far = home.position_m + np.array([2.0, 0.0, 0.0])  # 2 m beyond the arm's reach
    inside_torso = np.array([0.0, 0.0, 0.5])
    options = IKOptions(max_rounds=1, max_iterations=40)
    result = solve_pad_ik(kinematics, [far, inside_torso, home.position_m],
                          [[1.0, 0, 0], [0, 0, -1.0], home.z_axis], options=options)
    assert result.success.tolist() == [False, False, True]
    assert result.position_error_m[0] > 1.0
    assert result.position_error_m[1] > 1e-3 or result.angle_error_rad[1] > math.radians(1)


def test_roll_about_the_approach_axis_is_free(kinematics):
    """The same point and axis from two rolled configurations is one target: both are answers."""
    home = kinematics.forward_kinematics(kinematics.spec.home_q)
    result = PadIK(kinematics).solve(home.position_m, home.z_axis, q_seed=kinematics.spec.home_q)
    assert result.success[0]
    # the seed itself solves the task, so the closest solution is (almost) the seed
    assert np.abs(result.q_rad[0] - kinematics.spec.home_q).max() < 1e-6


def test_nearby_targets_give_nearby_solutions(kinematics):
    """Stepping the target 5 mm along the approach moves the joints a little, not to another posture."""
    home = kinematics.forward_kinematics(kinematics.spec.home_q)
    offsets = np.linspace(0.0, 0.02, 5)[:, None]
    result = PadIK(kinematics).solve(home.position_m + offsets * home.z_axis, np.tile(home.z_axis, (5, 1)))
    assert result.success.all()
    path = np.vstack([kinematics.spec.home_q, result.q_rad])
    assert np.abs(np.diff(path, axis=0)).max() < math.radians(5)


def test_approach_frames_have_the_approach_as_z_axis():
    approach = torch.tensor([[0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.6, 0.0, 0.8]], dtype=torch.float64)
    frames = approach_frames(approach, torch.tensor([0.0, 1.0, -2.0], dtype=torch.float64))
    assert torch.allclose(frames[:, :, 2], approach)
    assert torch.allclose(frames.transpose(1, 2) @ frames, torch.eye(3, dtype=torch.float64).expand(3, 3, 3))
    assert torch.allclose(torch.linalg.det(frames), torch.ones(3, dtype=torch.float64))
    # rolling by r turns the x axis by r about z
    base = approach_frames(approach[:1], torch.zeros(1, dtype=torch.float64))
    rolled = approach_frames(approach[:1], torch.tensor([0.3], dtype=torch.float64))
    assert float((base[0, :, 0] * rolled[0, :, 0]).sum()) == pytest.approx(math.cos(0.3))


def test_bad_ik_input_is_rejected(kinematics):
    ik = PadIK(kinematics)
    with pytest.raises(ValueError, match=r"positions_m must have shape \(n, 3\)"):
        ik.solve(np.zeros((2, 2)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match="zero vectors"):
        ik.solve(np.zeros((1, 3)), np.zeros((1, 3)))
    with pytest.raises(ValueError, match="2 positions but 1 approach"):
        ik.solve(np.zeros((2, 3)), np.ones((1, 3)))
    with pytest.raises(ValueError, match="q_seed is outside the joint limits"):
        ik.solve(np.zeros((1, 3)), np.ones((1, 3)), q_seed=kinematics.upper_rad + 1.0)
    with pytest.raises(ValueError, match="at least one candidate"):
        IKOptions(n_roll_candidates=0, n_random_seeds=0)
