"""Link-length errors: the closed-form shift against a rewritten URDF, the simulator's true arm, and
their calibration from exact ball touches (known injected errors)."""
from __future__ import annotations

import math

import numpy as np
import pytest

import robots
from common.rotations import matrix_to_quat
from robots.ik import solve_pad_ik
from robots.joint_calibration import SphereTouches, fit_joint_offsets, sphere_residuals_m
from robots.kinematics import ArmKinematics
from robots.link_lengths import arm_link_lengths, link_length_shift_m, with_link_length_errors

INJECTED_M = {"elbow": 0.0012, "wrist_1": -0.0008, "hand_to_tool": 0.0015}


@pytest.fixture(scope="module")
def nominal():
    return ArmKinematics(robots.load("armar3"))


@pytest.fixture(scope="module")
def true_kinematics(nominal, tmp_path_factory):
    """An independent model of the longer arm: pytorch_kinematics on the rewritten URDF."""
    return ArmKinematics(with_link_length_errors(nominal.spec, INJECTED_M, tmp_path_factory.mktemp("urdf")))


def test_the_arm_links_are_upper_arm_forearm_and_hand():
    links = arm_link_lengths(robots.load("armar3"))
    assert [(link.joint, round(link.length_m, 3)) for link in links] == [
        ("elbow", 0.311), ("wrist_1", 0.24), ("hand_to_tool", 0.13)]
    assert "shoulder_1" in [link.joint for link in arm_link_lengths(robots.load("armar6"))]  # clavicle offset


def test_closed_form_shift_matches_the_rewritten_urdf(nominal, true_kinematics):
    spec = nominal.spec
    q = spec.home_q + 0.5 * np.random.default_rng(3).uniform(-1, 1, (25, spec.dof))
    moved = true_kinematics.forward_kinematics(q).position_m - nominal.forward_kinematics(q).position_m
    assert np.linalg.norm(moved, axis=1).min() > 5e-4  # the errors move the pad
    np.testing.assert_allclose(link_length_shift_m(nominal, q, INJECTED_M), moved, atol=1e-7)
    # rotations are untouched: the IMU sees the same orientation on both arms
    np.testing.assert_allclose(true_kinematics.forward_kinematics(q).rotation,
                               nominal.forward_kinematics(q).rotation, atol=1e-9)


def test_bad_link_names_and_sizes_are_refused(nominal, tmp_path):
    with pytest.raises(ValueError, match="not link lengths of the arm"):
        with_link_length_errors(nominal.spec, {"spring_x": 0.001}, tmp_path)
    with pytest.raises(ValueError, match="below half the link"):
        link_length_shift_m(nominal, nominal.spec.home_q, {"hand_to_tool": 0.1})


def test_the_simulated_arm_is_the_longer_one(nominal):
    from robots.sim_arm import SimArm
    from robots.sim_world import SimWorld

    spec = nominal.spec
    with SimWorld(table=None) as world:
        arm = SimArm(world, spec, link_length_error_m=INJECTED_M)
        truth = arm.link_state(spec.pad_link).position_m
    expected = nominal.forward_kinematics(spec.home_q).position_m + link_length_shift_m(nominal, spec.home_q,
                                                                                      INJECTED_M)[0]
    np.testing.assert_allclose(truth, expected, atol=2e-5)  # PyBullet's float32 link frames


def test_profile_draws_seeded_link_errors():
    from explorer.sim_profile import get_profile

    spec = robots.load("armar3")
    hardware = get_profile("hardware-like")
    first, again, other = (hardware.link_length_errors_m(spec, s) for s in (0, 0, 1))
    assert first == again and first != other and set(first) == {"elbow", "wrist_1", "hand_to_tool"}
    assert get_profile("datasheet-noise").link_length_errors_m(spec, 0) == {}


def test_exact_ball_touches_give_back_offsets_and_link_lengths(nominal, true_kinematics):
    """Touches by the longer arm, read through offset encoders; fitted on the nominal model."""
    spec = nominal.spec
    rng = np.random.default_rng(1)
    places = np.asarray(spec.workspace_center_m, float) + np.array([[0, 0, 0], [0.0, 0.12, 0.0], [0, -0.06, 0.12]])
    facing = -nominal.forward_kinematics(spec.home_q).z_axis
    normals = []
    while len(normals) < 48:
        n = rng.standard_normal(3)
        n /= np.linalg.norm(n)
        if n @ facing > math.cos(math.radians(60)):
            normals.append(n)
    normals = np.array(normals)
    centres = places[np.arange(len(normals)) % 3]
    ik = solve_pad_ik(true_kinematics, centres + 0.05 * normals, -normals, q_seed=spec.home_q)
    q_true = ik.q_rad[ik.success]
    assert len(q_true) >= 18
    pad = true_kinematics.forward_kinematics(q_true)
    body = true_kinematics.forward_kinematics(q_true, spec.sensor_body_link)
    radius = 0.05
    centre = pad.position_m + radius * pad.z_axis  # the pad lies flat on the ball: exact touches
    offsets = np.radians([0.4, -0.3, 0.2, 0.5, 0.0, 0.0, 0.0])
    touches = SphereTouches(q_true + offsets, matrix_to_quat(body.rotation), centre, radius)
    assert np.abs(sphere_residuals_m(nominal, touches, offsets, INJECTED_M)).max() < 1e-7

    only_offsets = fit_joint_offsets(nominal, touches, ridge_m_per_rad=0.0)
    fit = fit_joint_offsets(nominal, touches, ridge_m_per_rad=0.0, link_lengths=True, ridge_m_per_m=0.0)
    assert np.sqrt(np.mean(only_offsets.residual_after_m**2)) > 1e-4  # offsets alone cannot explain it
    assert np.abs(fit.residual_after_m).max() < 1e-6
    for name, value in INJECTED_M.items():
        assert fit.link_length_error_m[name] == pytest.approx(value, abs=2e-5)
    np.testing.assert_allclose(fit.offset_rad[:4], offsets[:4], atol=math.radians(0.01))
    assert fit.parameter_std.shape == (spec.dof + 3,)
