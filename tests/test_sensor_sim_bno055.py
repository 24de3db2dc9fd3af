"""Simulated BNO055: closed-form kinematics, data-sheet rates and noise statistics."""
import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from common.pad_state import PadState
from sensor.sim.bno055 import BNO055Config, BNO055Noise, SimulatedBNO055
from common.rotations import rotation_from_wxyz

G = 9.80665


def quat_about_x(angle_rad):
    return np.array([math.cos(angle_rad / 2), math.sin(angle_rad / 2), 0.0, 0.0])


def pad_state(t_s, quat=(1.0, 0.0, 0.0, 0.0), velocity=(0.0, 0.0, 0.0)):
    return PadState(t_s, np.zeros(3), np.asarray(quat, float), np.asarray(velocity, float), np.zeros(3), 0.0)


def run(config, states, seed=0):
    chip = SimulatedBNO055(config, np.random.default_rng(seed))
    return [s for s in map(chip.step, states) if s is not None]


def only(**noise):
    """Config with every noise source off except the given ones, no quantisation."""
    return BNO055Config(noise=replace(BNO055Noise.off(), **noise), quantise=False)


def test_fusion_rate_is_100_hz_on_a_240_hz_physics_clock():
    samples = run(BNO055Config(), [pad_state(t) for t in np.arange(0.0, 5.0, 1.0 / 240.0)])
    assert len(samples) == 500
    assert np.all(np.diff([s.t_s for s in samples]) > 0.0)


def test_noiseless_quaternion_is_the_truth_within_one_lsb():
    rng = np.random.default_rng(1)
    truths = Rotation.random(50, random_state=2).as_quat()[:, [3, 0, 1, 2]]
    truths[rng.random(50) < 0.5] *= -1.0  # either hemisphere
    states = [pad_state(0.01 * k, q) for k, q in enumerate(truths)]
    samples = run(BNO055Config().noiseless(), states)
    for sample, truth in zip(samples, truths):
        assert np.max(np.abs(sample.quat_wxyz - truth)) <= 1.5 * 2.0**-14  # same sign as the input
        assert np.linalg.norm(sample.quat_wxyz) == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("angle_deg", [0.0, 30.0, 90.0, 180.0])
def test_gravity_reads_up_in_sensor_frame(angle_deg):
    theta = math.radians(angle_deg)
    samples = run(BNO055Config().noiseless(), [pad_state(0.01 * k, quat_about_x(theta)) for k in range(3)])
    # R_x(theta)^T (0, 0, g) = (0, g sin theta, g cos theta)
    expected = np.array([0.0, G * math.sin(theta), G * math.cos(theta)])
    np.testing.assert_allclose(samples[-1].gravity_mps2, expected, atol=0.005 + 1e-9)


def test_linear_acceleration_is_world_acceleration_in_sensor_frame():
    theta = math.radians(40.0)
    a_world = np.array([0.5, -0.2, 1.0])
    states = [pad_state(t, quat_about_x(theta), a_world * t) for t in np.arange(0.0, 0.5, 1.0 / 240.0)]
    samples = run(BNO055Config().noiseless(), states)
    c, s = math.cos(theta), math.sin(theta)
    expected = np.array([a_world[0], c * a_world[1] + s * a_world[2], -s * a_world[1] + c * a_world[2]])
    np.testing.assert_allclose(samples[0].lin_acc_mps2, 0.0)  # no velocity history yet
    for sample in samples[1:]:
        np.testing.assert_allclose(sample.lin_acc_mps2, expected, atol=0.005 + 1e-9)


def test_accelerometer_noise_follows_datasheet_density_and_bandwidth():
    config = only(accel_noise_density_mps2_per_sqrt_hz=150e-6 * G)
    samples = run(config, [pad_state(0.01 * k) for k in range(10000)])
    lin_acc = np.array([s.lin_acc_mps2 for s in samples])
    expected = 150e-6 * G * math.sqrt(62.5)  # Table 0-2 density over the Table 3-4 bandwidth
    assert expected == pytest.approx(0.01163, rel=1e-3)
    np.testing.assert_allclose(np.std(lin_acc, axis=0), expected, rtol=0.04)
    np.testing.assert_allclose(np.mean(lin_acc, axis=0), 0.0, atol=4 * expected / 100)


def test_accelerometer_bias_is_constant_per_power_on():
    config = only(accel_bias_std_mps2=0.05)
    biases = [run(config, [pad_state(0.01 * k) for k in range(20)], seed=seed) for seed in range(300)]
    first = np.array([b[0].lin_acc_mps2 for b in biases])
    last = np.array([b[-1].lin_acc_mps2 for b in biases])
    np.testing.assert_allclose(first, last, atol=1e-12)
    assert np.std(first) == pytest.approx(0.05, rel=0.1)


def test_white_orientation_noise_has_the_configured_rms_per_axis():
    sigma = BNO055Noise().orientation_white_std_rad
    assert math.degrees(sigma) == pytest.approx(0.068, abs=0.001)  # derived from the data sheet
    truth = np.array([0.9, 0.1, -0.3, 0.2]) / np.linalg.norm([0.9, 0.1, -0.3, 0.2])
    samples = run(only(orientation_white_std_rad=sigma), [pad_state(0.01 * k, truth) for k in range(8000)])
    errors = (rotation_from_wxyz(truth).inv() * rotation_from_wxyz([s.quat_wxyz for s in samples])).as_rotvec()
    np.testing.assert_allclose(np.std(errors, axis=0), sigma, rtol=0.04)


def test_heading_random_walk_is_about_world_vertical_at_gyro_noise_rate():
    rate = math.radians(0.014)  # Table 0-2 gyroscope noise density, integrated
    truth = quat_about_x(math.radians(25.0))
    samples = run(only(yaw_random_walk_rad_per_sqrt_s=rate), [pad_state(float(t), truth) for t in range(4000)])
    errors_world = (rotation_from_wxyz([s.quat_wxyz for s in samples]) * rotation_from_wxyz(truth).inv()).as_rotvec()
    np.testing.assert_allclose(errors_world[:, :2], 0.0, atol=1e-12)  # no tilt
    assert np.std(np.diff(errors_world[:, 2])) == pytest.approx(rate, rel=0.05)  # per 1 s step


def test_tilt_bias_is_bounded_with_the_configured_rms_and_correlation_time():
    std, tau, dt = math.radians(0.2), 1.0, 0.5
    config = only(tilt_bias_std_rad=std, tilt_bias_time_constant_s=tau)
    samples = run(config, [pad_state(dt * k) for k in range(8000)])
    tilt = rotation_from_wxyz([s.quat_wxyz for s in samples]).as_rotvec()
    np.testing.assert_allclose(tilt[:, 2], 0.0, atol=1e-12)
    np.testing.assert_allclose(np.std(tilt[:, :2], axis=0), std, rtol=0.08)
    lag_one = [np.corrcoef(tilt[:-1, i], tilt[1:, i])[0, 1] for i in (0, 1)]
    np.testing.assert_allclose(lag_one, math.exp(-dt / tau), atol=0.04)  # Ornstein-Uhlenbeck


def test_tilt_error_leaks_gravity_into_linear_acceleration():
    config = only(tilt_bias_std_rad=math.radians(1.0), tilt_bias_time_constant_s=5.0)
    samples = run(config, [pad_state(0.01 * k) for k in range(500)])
    for s in samples[1:]:
        tilt = 2.0 * math.acos(min(1.0, abs(s.quat_wxyz[0])))
        # |R^T g - R_est^T g| = 2 g sin(tilt / 2) at rest
        assert np.linalg.norm(s.lin_acc_mps2) == pytest.approx(2.0 * G * math.sin(tilt / 2.0), rel=1e-9, abs=1e-12)


def test_seeded_streams_repeat_and_differ_between_seeds():
    states = [pad_state(0.01 * k) for k in range(50)]
    a, b, c = (run(BNO055Config(), states, seed=s) for s in (5, 5, 6))
    assert all(np.array_equal(x.quat_wxyz, y.quat_wxyz) for x, y in zip(a, b))
    assert not all(np.array_equal(x.quat_wxyz, y.quat_wxyz) for x, y in zip(a, c))


def test_bad_settings_are_refused_by_name():
    with pytest.raises(ValueError, match="output_rate_hz"):
        BNO055Config(output_rate_hz=0.0)
    with pytest.raises(ValueError, match="orientation_white_std_rad"):
        BNO055Noise(orientation_white_std_rad=-1e-3)
    with pytest.raises(ValueError, match="tilt_bias_time_constant_s"):
        BNO055Noise(tilt_bias_time_constant_s=0.0)
