"""Joint-offset calibration from sphere touches recovers injected offsets against the known truth."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import robots
from robots.ik import solve_pad_ik
from robots.joint_calibration import SphereTouches, fit_joint_offsets, sphere_residuals_m
from robots.kinematics import ArmKinematics
from common.rotations import matrix_to_quat


@pytest.fixture(scope="module")
def kinematics():
    return ArmKinematics(robots.load("armar3"))


@pytest.fixture(scope="module")
def true_touches(kinematics):
    """Exact touches of a 5 cm ball at three known places: true joint angles, pad flat on the surface."""
    spec = kinematics.spec
    places = np.asarray(spec.workspace_center_m, float) + np.array([[0, 0, 0], [0.0, 0.12, 0.0], [0, -0.06, 0.12]])
    radius = 0.05
    rng = np.random.default_rng(1)
    facing = -kinematics.forward_kinematics(spec.home_q).z_axis  # the surface the arm faces at home
    normals, centres = [], []
    while len(normals) < 60:
        n = rng.standard_normal(3)
        n /= np.linalg.norm(n)
        if n @ facing > math.cos(math.radians(60)):
            normals.append(n)
            centres.append(places[len(normals) % 3])
    normals, centres = np.array(normals), np.array(centres)
    ik = solve_pad_ik(kinematics, centres + radius * normals, -normals, q_seed=spec.home_q)
    assert ik.success.sum() >= 30
    q_true = ik.q_rad[ik.success]
    body = kinematics.forward_kinematics(q_true, spec.sensor_body_link)
    return q_true, matrix_to_quat(body.rotation), centres[ik.success], radius


def test_exact_touches_give_back_the_injected_offsets(kinematics, true_touches):
    q_true, quats, centre, radius = true_touches
    injected = np.radians([0.6, -0.4, 0.3, 0.5, -0.7, 0.2, -0.3])
    touches = SphereTouches(q_true + injected, quats, centre, radius)
    assert np.abs(sphere_residuals_m(kinematics, touches, injected)).max() < 1e-3  # consistent (IK tolerance)
    fit = fit_joint_offsets(kinematics, touches, ridge_m_per_rad=0.0)
    assert np.abs(fit.residual_before_m).max() > 3e-3  # the error was there
    assert np.abs(fit.residual_after_m).max() < 1e-3
    # shoulder and elbow offsets move the fingertip most and are recovered one by one
    np.testing.assert_allclose(fit.offset_rad[:4], injected[:4], atol=math.radians(0.1))
    # the forearm and wrist offsets show only through the short lever to the pivot (their singular
    # values are ~100x smaller): what matters is the pivot the loop computes, also at untouched poses
    spec = kinematics.spec
    held_out = spec.home_q + np.radians(15.0) * np.random.default_rng(2).uniform(-1, 1, (50, 7))
    truth = kinematics.forward_kinematics(held_out, spec.pivot_link).position_m
    before = kinematics.forward_kinematics(held_out + injected, spec.pivot_link).position_m - truth
    after = kinematics.forward_kinematics(held_out + injected - fit.offset_rad, spec.pivot_link).position_m - truth
    assert np.linalg.norm(before, axis=1).mean() > 5e-3
    assert np.linalg.norm(after, axis=1).mean() < 0.3 * np.linalg.norm(before, axis=1).mean()


def test_noisy_touches_still_shrink_the_offset_error(kinematics, true_touches):
    q_true, quats, centre, radius = true_touches
    rng = np.random.default_rng(7)
    injected = np.radians(0.5) * rng.standard_normal(7)
    q_read = q_true + injected + np.radians(0.05) * rng.standard_normal(q_true.shape)  # backlash, resolution
    turned = Rotation.from_rotvec(np.radians(2.0) * rng.standard_normal((len(quats), 3)))  # IMU error
    noisy = (Rotation.from_quat(quats[:, [1, 2, 3, 0]]) * turned).as_quat()[:, [3, 0, 1, 2]]
    fit = fit_joint_offsets(kinematics, SphereTouches(q_read, noisy, centre, radius))
    assert np.sqrt(np.mean(fit.residual_after_m**2)) < 0.3 * np.sqrt(np.mean(fit.residual_before_m**2))
    # the pad position error the offsets cause, over the touched poses, before vs after
    truth = kinematics.forward_kinematics(q_true).position_m
    before = kinematics.forward_kinematics(q_true + injected).position_m - truth
    after = kinematics.forward_kinematics(q_true + injected - fit.offset_rad).position_m - truth
    assert np.linalg.norm(after, axis=1).mean() < 0.6 * np.linalg.norm(before, axis=1).mean()


def test_too_few_touches_are_refused(kinematics, true_touches):
    q_true, quats, centre, radius = true_touches
    with pytest.raises(ValueError, match="cannot determine 7 joint offsets"):
        fit_joint_offsets(kinematics, SphereTouches(q_true[:3], quats[:3], centre[:3], radius))


class _LimitedArm:
    """An arm that refuses commands past its limits, as the simulated and real arms do."""

    dof = 2
    lower_rad = np.array([-1.0, -0.5])
    upper_rad = np.array([1.0, 0.5])

    def __init__(self):
        self.q = np.zeros(2)

    def move_joints(self, q, speed_rad_s=1.0):
        q = np.asarray(q, float)
        if np.any(q < self.lower_rad) or np.any(q > self.upper_rad):
            raise ValueError("q is outside the joint limits")
        self.q = q

    def joint_positions(self):
        return self.q.copy()


def test_a_calibrated_arm_stops_at_its_real_limit_instead_of_refusing_a_nominal_one():
    from robots.joint_calibration import CalibratedRobot

    inner = _LimitedArm()
    offset = np.array([0.05, -0.02])
    arm = CalibratedRobot(inner, offset)
    arm.move_joints([0.2, 0.1])  # well inside: sent shifted by the offset, read back corrected
    np.testing.assert_allclose(inner.q, [0.25, 0.08])
    np.testing.assert_allclose(arm.joint_positions(), [0.2, 0.1])
    arm.move_joints(inner.upper_rad)  # the nominal limit: the shifted command would pass the real one
    np.testing.assert_allclose(inner.q, [1.0, 0.48])
    np.testing.assert_allclose(arm.joint_positions(), [1.0 - 0.05, 0.5])


def test_cross_validation_keeps_a_small_ridge_for_clean_touches_and_a_large_one_for_noise(kinematics, true_touches):
    """Clean touches of a real offset: the fit needs freedom (a small ridge predicts left-out touches
    best). Touches of a true arm (no offset) with large IMU noise: any offset only fits noise, so the
    chosen ridge is larger and the fitted offsets smaller than the smallest ridge's."""
    from robots.joint_calibration import RIDGE_LADDER_M_PER_RAD, cross_validated_ridge

    q_true, quats, centre, radius = true_touches
    injected = np.radians([0.6, -0.4, 0.3, 0.5, -0.7, 0.2, -0.3])
    clean = cross_validated_ridge(kinematics, SphereTouches(q_true + injected, quats, centre, radius))
    assert clean.ridge_m_per_rad <= 0.1
    assert clean.scores_m[RIDGE_LADDER_M_PER_RAD[0]][0] < clean.scores_m[RIDGE_LADDER_M_PER_RAD[-1]][0]

    rng = np.random.default_rng(3)
    turned = Rotation.from_rotvec(np.radians(6.0) * rng.standard_normal((len(quats), 3)))
    noisy = SphereTouches(q_true, (Rotation.from_quat(quats[:, [1, 2, 3, 0]]) * turned).as_quat()[:, [3, 0, 1, 2]],
                          centre, radius)
    choice = cross_validated_ridge(kinematics, noisy)
    assert choice.ridge_m_per_rad > RIDGE_LADDER_M_PER_RAD[0]
    loose = fit_joint_offsets(kinematics, noisy, ridge_m_per_rad=RIDGE_LADDER_M_PER_RAD[0]).offset_rad
    chosen = fit_joint_offsets(kinematics, noisy, ridge_m_per_rad=choice.ridge_m_per_rad).offset_rad
    assert np.linalg.norm(chosen) < np.linalg.norm(loose)


def _pivot_error_m(kinematics, injected, fitted) -> float:
    """Mean pivot position error, metres, at 50 poses none of the touches used."""
    spec = kinematics.spec
    poses = spec.home_q + np.radians(15.0) * np.random.default_rng(2).uniform(-1, 1, (50, spec.dof))
    truth = kinematics.forward_kinematics(poses, spec.pivot_link).position_m
    computed = kinematics.forward_kinematics(poses + injected - fitted, spec.pivot_link).position_m
    return float(np.linalg.norm(computed - truth, axis=1).mean())


def test_a_robust_fit_lets_touches_off_the_ball_go(kinematics, true_touches):
    """A fifth of the touches 3-6 mm off the sphere (a pad that did not lie flat): least squares
    bends the offsets towards them, the robust fit recovers the arm as if they were not there."""
    from robots.joint_calibration import ROBUST_RIDGE_M_PER_RAD, ROBUST_SCALE_M

    q_true, quats, centre, radius = true_touches
    injected = np.radians([0.6, -0.4, 0.3, 0.5, -0.7, 0.2, -0.3])
    rng = np.random.default_rng(5)
    pads = kinematics.pad_position_from_orientation(q_true, quats)
    outward = (pads - centre) / np.linalg.norm(pads - centre, axis=1, keepdims=True)
    off = rng.random(len(q_true)) < 0.2
    shifted = centre - np.where(off, rng.uniform(3e-3, 6e-3, len(q_true)), 0.0)[:, None] * outward
    touches = SphereTouches(q_true + injected, quats, shifted, radius)
    assert off.sum() >= 4
    plain = fit_joint_offsets(kinematics, touches, ridge_m_per_rad=ROBUST_RIDGE_M_PER_RAD)
    robust = fit_joint_offsets(kinematics, touches, ridge_m_per_rad=ROBUST_RIDGE_M_PER_RAD,
                               robust_scale_m=ROBUST_SCALE_M)
    clean = fit_joint_offsets(kinematics, SphereTouches(q_true + injected, quats, centre, radius),
                              ridge_m_per_rad=ROBUST_RIDGE_M_PER_RAD, robust_scale_m=ROBUST_SCALE_M)
    # shoulder and elbow offsets (the ones the touches determine: the first test) as if clean
    robust_error = np.abs(robust.offset_rad - injected)[:4]
    assert robust_error.max() < math.radians(0.05)
    assert np.abs(clean.offset_rad - injected)[:4].max() < math.radians(0.05)
    assert np.abs(plain.offset_rad - injected)[:4].max() > 3 * robust_error.max()
    # and what the loop computes: the pivot at untouched poses
    assert _pivot_error_m(kinematics, injected, robust.offset_rad) < _pivot_error_m(kinematics, injected,
                                                                                    plain.offset_rad)
    assert _pivot_error_m(kinematics, injected, robust.offset_rad) < 0.2 * _pivot_error_m(kinematics, injected, 0.0)
    # the touches off the ball are the ones left with large residuals
    assert np.all(np.abs(robust.residual_after_m[off]) > 2e-3)
    assert np.median(np.abs(robust.residual_after_m[~off])) < 0.5e-3


def test_the_robust_fit_reports_the_unweighted_jacobian(kinematics, true_touches):
    """Its singular values are those of the touch residuals themselves, as plain least squares
    reports them (scipy's Jacobian there), not of the loss-weighted rows."""
    q_true, quats, centre, radius = true_touches
    touches = SphereTouches(q_true + np.radians(0.3), quats, centre, radius)
    plain = fit_joint_offsets(kinematics, touches, ridge_m_per_rad=0.0)
    robust = fit_joint_offsets(kinematics, touches, ridge_m_per_rad=0.0, robust_scale_m=1.0)  # ~ quadratic
    np.testing.assert_allclose(robust.offset_rad, plain.offset_rad, atol=math.radians(0.01))
    np.testing.assert_allclose(robust.singular_values, plain.singular_values, rtol=1e-3)
    with pytest.raises(ValueError, match="robust_scale_m must be positive"):
        fit_joint_offsets(kinematics, touches, robust_scale_m=-1e-3)


def test_the_pads_compression_is_fitted_from_each_touchs_force(kinematics, true_touches):
    """Each pad face sank 2 mm per newton into the ball at forces of 0.1-3 N (the face centre is
    that far inside the sphere along its normal): left out, the compression bends the offsets;
    with the forces the fit gives back the injected compliance and the offsets."""
    q_true, quats, centre, radius = true_touches
    injected = np.radians([0.6, -0.4, 0.3, 0.5, -0.7, 0.2, -0.3])
    compliance = 2e-3
    force = np.random.default_rng(9).uniform(0.1, 3.0, len(q_true))
    pads = kinematics.pad_position_from_orientation(q_true, quats)
    outward = (pads - centre) / np.linalg.norm(pads - centre, axis=1, keepdims=True)
    sunk = centre + (compliance * force)[:, None] * outward  # the same as the face sinking into the ball
    with_force = SphereTouches(q_true + injected, quats, sunk, radius, force)
    assert np.abs(sphere_residuals_m(kinematics, with_force, injected, None, compliance)).max() < 1e-3
    fit = fit_joint_offsets(kinematics, with_force, ridge_m_per_rad=0.0)
    assert fit.pad_compliance_m_per_n == pytest.approx(compliance, rel=0.05)
    np.testing.assert_allclose(fit.offset_rad[:4], injected[:4], atol=math.radians(0.1))
    assert fit.parameter_std.shape == (kinematics.dof + 1,)
    without = fit_joint_offsets(kinematics, SphereTouches(q_true + injected, quats, sunk, radius), ridge_m_per_rad=0.0)
    assert without.pad_compliance_m_per_n is None
    assert _pivot_error_m(kinematics, injected, fit.offset_rad) < 0.5 * _pivot_error_m(kinematics, injected,
                                                                                       without.offset_rad)
    with pytest.raises(ValueError, match="force_n must be"):
        SphereTouches(q_true, quats, centre, radius, force[:-1])
    with pytest.raises(ValueError, match="needs each touch's force"):
        fit_joint_offsets(kinematics, SphereTouches(q_true, quats, centre, radius), pad_compliance=True)


def test_the_resolution_says_which_offsets_the_touches_determine(kinematics, true_touches):
    """With one ridge weight on every offset the resolution is ``V diag(s^2 / (s^2 + w^2)) V^T``
    from the SVD of the touch residuals' Jacobian (here by central differences, independent of the
    fit's). The shoulder and elbow are determined; the wrist, which turns the pad about points near
    it, is held at zero by the ridge, and a vanishing ridge gives every offset back to the touches."""
    q_true, quats, centre, radius = true_touches
    injected = np.radians([0.6, -0.4, 0.3, 0.5, -0.7, 0.2, -0.3])
    touches = SphereTouches(q_true + injected, quats, centre, radius)
    weight = 0.2
    fit = fit_joint_offsets(kinematics, touches, ridge_m_per_rad=weight)
    step = 1e-6
    jac = np.stack([(sphere_residuals_m(kinematics, touches, fit.offset_rad + step * e)
                     - sphere_residuals_m(kinematics, touches, fit.offset_rad - step * e)) / (2 * step)
                    for e in np.eye(kinematics.dof)], axis=1)
    _, s, vt = np.linalg.svd(jac, full_matrices=False)
    expected = np.einsum("ki,k->i", vt**2, s**2 / (s**2 + weight**2))
    np.testing.assert_allclose(fit.resolution, expected, atol=1e-3)
    assert np.all(fit.resolution[:4] > 0.5) and np.all(fit.resolution[-2:] < 0.5)
    assert set(fit.unresolved()) >= {5, 6}
    assert np.all(fit_joint_offsets(kinematics, touches, ridge_m_per_rad=1e-6).resolution > 0.99)
