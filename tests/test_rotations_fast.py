"""The plain-float rotation helpers and the fast simulated-sensor paths against independent answers:
scipy's Rotation, the BNO055 model as written with scipy, and the sensor fed every step."""
import math
from collections import deque

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from common.pad_state import PadState
from common.rotations import (quat_from_rotvec_wxyz, quat_multiply_wxyz, quat_normalised_wxyz,
                              quat_rotate_inverse_wxyz, rotation_from_wxyz, wxyz_from_rotation)
from sensor.sim.bno055 import BNO055Config, BNO055Noise, SimulatedBNO055
from sensor.sim_sensor import SimulatedSensorConfig, SimulatedTactileSensor

RNG = np.random.default_rng(11)


def random_quats(n):
    return Rotation.random(n, random_state=3).as_quat()[:, [3, 0, 1, 2]] * RNG.choice([-1.0, 1.0], (n, 1))


def test_product_is_scipys_composition():
    for a, b in zip(random_quats(200), random_quats(200)[::-1]):
        expected = wxyz_from_rotation(rotation_from_wxyz(a) * rotation_from_wxyz(b))
        product = np.array(quat_multiply_wxyz(a, b))
        np.testing.assert_allclose(product * np.sign(product @ expected), expected, atol=1e-15)


@pytest.mark.parametrize("scale", [1e-9, 1e-4, 9.9e-4, 1.01e-3, 0.1, 3.0])
def test_rotvec_is_scipys_across_the_small_angle_switch(scale):
    for v in RNG.normal(size=(100, 3)) * scale:
        expected = wxyz_from_rotation(Rotation.from_rotvec(v))
        np.testing.assert_allclose(quat_from_rotvec_wxyz(*v), expected, rtol=1e-15, atol=1e-16)


def test_inverse_rotation_is_scipys():
    for q, v in zip(random_quats(200), RNG.normal(size=(200, 3)) * 10.0):
        expected = rotation_from_wxyz(q).inv().apply(v)
        np.testing.assert_allclose(quat_rotate_inverse_wxyz(q, v), expected, atol=1e-13)


def test_normalised_is_unit_and_keeps_the_direction():
    q = quat_normalised_wxyz([2.0, 0.0, -1.0, 0.5])
    assert math.fsum(c * c for c in q) == pytest.approx(1.0, abs=1e-15)
    np.testing.assert_allclose(np.array(q) * np.linalg.norm([2.0, 0.0, -1.0, 0.5]), [2.0, 0.0, -1.0, 0.5])


class ScipyBNO055:
    """The BNO055 sample maths as first written with scipy Rotation objects (the reference)."""

    def __init__(self, config, rng):
        self.config, self._rng = config, rng
        noise = config.noise
        self._accel_bias = noise.accel_bias_std_mps2 * rng.standard_normal(3)
        self._tilt_bias = noise.tilt_bias_std_rad * rng.standard_normal(2)
        self.mounting = Rotation.from_rotvec(noise.mounting_misalignment_std_rad * rng.standard_normal(3))
        self._yaw_bias = noise.heading_offset_std_rad * rng.standard_normal() if noise.heading_offset_std_rad else 0.0
        self._last = None

    def measure(self, state, t):
        noise, rng = self.config.noise, self._rng
        velocity = np.asarray(state.lin_vel_mps, float)
        acceleration = np.zeros(3)
        if self._last is not None:
            dt = t - self._last[0]
            acceleration = (velocity - self._last[1]) / dt
            self._yaw_bias += noise.yaw_random_walk_rad_per_sqrt_s * math.sqrt(dt) * rng.standard_normal()
            keep = math.exp(-dt / noise.tilt_bias_time_constant_s)
            self._tilt_bias = (keep * self._tilt_bias
                               + noise.tilt_bias_std_rad * math.sqrt(1.0 - keep * keep) * rng.standard_normal(2))
        self._last = (t, velocity)
        chip = rotation_from_wxyz(state.quat_wxyz) * self.mounting
        world_error = Rotation.from_rotvec([self._tilt_bias[0], self._tilt_bias[1], self._yaw_bias])
        body_error = Rotation.from_rotvec(noise.orientation_white_std_rad * rng.standard_normal(3))
        measured = world_error * chip * body_error
        up = np.array([0.0, 0.0, self.config.gravity_mps2])
        specific_force = chip.inv().apply(acceleration + up)
        specific_force += self._accel_bias + self.config.accel_noise_std_mps2 * rng.standard_normal(3)
        gravity = measured.inv().apply(up)
        quat = wxyz_from_rotation(measured)
        return quat * np.sign(quat @ state.quat_wxyz), specific_force - gravity, gravity


def moving_states(n, dt=1.0 / 480.0):
    """A pad turning and accelerating: (n,) PadStates, one per physics step."""
    states = []
    for k in range(n):
        t = k * dt
        rotation = Rotation.from_rotvec([0.8 * math.sin(3.0 * t), 0.5 * t, -1.2 + 0.3 * math.cos(5.0 * t)])
        quat = wxyz_from_rotation(rotation)
        velocity = np.array([0.1 * math.sin(7.0 * t), 0.05 * t, -0.02 * math.cos(2.0 * t)])
        force = max(0.0, 4.0 * math.sin(2.0 * t))
        states.append(PadState(t, np.zeros(3), quat * (1.0 if k % 3 else -1.0), velocity, np.zeros(3), force))
    return states


@pytest.mark.parametrize("heading_offset", [0.0, 0.05])
def test_bno055_samples_equal_the_scipy_model(heading_offset):
    noise = BNO055Noise(heading_offset_std_rad=heading_offset, tilt_bias_std_rad=0.05,
                        yaw_random_walk_rad_per_sqrt_s=0.05, mounting_misalignment_std_rad=0.1)
    config = BNO055Config(noise=noise, quantise=False)
    chip = SimulatedBNO055(config, np.random.default_rng(5))
    reference = ScipyBNO055(config, np.random.default_rng(5))
    count = 0
    for state in moving_states(2000):
        sample = chip.step(state)
        if sample is None:
            continue
        quat, lin_acc, gravity = reference.measure(state, state.t_s)
        np.testing.assert_allclose(sample.quat_wxyz, quat, atol=1e-14)
        np.testing.assert_allclose(sample.gravity_mps2, gravity, atol=1e-12)
        np.testing.assert_allclose(sample.lin_acc_mps2, lin_acc, atol=1e-10)
        count += 1
    assert count > 300


@pytest.mark.parametrize("latency_s", [0.0, 0.013])
def test_force_only_steps_give_the_readings_of_whole_pad_states(latency_s):
    """What explorer.simulation.connect_sensor relies on: on steps where the sensor does not
    need the pad state, the force alone produces exactly the same readings."""
    config = SimulatedSensorConfig(imu=BNO055Config(latency_s=latency_s))
    every_step, lazy = (SimulatedTactileSensor(config=config, seed=9) for _ in range(2))
    every_step.open()
    lazy.open()
    skipped = deque()
    for state in moving_states(3000):
        every_step.on_step(state)
        if lazy.needs_pad_state(state.t_s):
            lazy.on_step(state)
        else:
            lazy.on_force_step(state.t_s, state.normal_force_n)
            skipped.append(state.t_s)
    assert (len(skipped) > 2000) == (latency_s == 0.0)  # only the IMU's sample steps need the pose
    expected, got = every_step.drain(), lazy.drain()
    assert len(got) == len(expected) > 500
    for a, b in zip(expected, got):
        assert all(np.array_equal(getattr(a, f), getattr(b, f)) for f in vars(a))


def test_force_only_step_is_refused_where_the_imu_samples():
    sensor = SimulatedTactileSensor(seed=1)
    sensor.open()
    with pytest.raises(ValueError, match="on_step"):
        sensor.on_force_step(0.0, 0.0)  # the first step is an IMU sample
    state = moving_states(1)[0]
    sensor.on_step(state)
    with pytest.raises(ValueError, match="normal force"):
        sensor.on_force_step(0.001, -1.0)
