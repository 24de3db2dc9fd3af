"""Normal, force and contact point of a confirmed contact: closed forms and an end-to-end press."""
import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from sensor.contact_detection import PressureContactDetector
from sensor.normal_estimation import (ImuAlignment, OrientationNotSettledError, SettlingConfig, average_quaternion,
                                      estimate_normal, face_normal_world, oriented_contact)
from sensor.oriented_contact import OrientedContact
from common.pad_state import PadState
from sensor.reading import Reading
from sensor.sim.bno055 import BNO055Config, BNO055Noise
from sensor.sim.pad_response import PadResponse
from common.rotations import rotation_from_wxyz, wxyz_from_rotation
from sensor.sim_sensor import SimulatedSensorConfig, SimulatedTactileSensor

BASELINE = 101325.0


def quat_about_x(angle_rad):
    return np.array([math.cos(angle_rad / 2), math.sin(angle_rad / 2), 0.0, 0.0])


def readings(times, quats, pressure_pa=BASELINE + 500.0):
    return [Reading(t_s=t, pressure_pa=pressure_pa, quat_wxyz=np.asarray(q, float), lin_acc_mps2=np.zeros(3),
                    gravity_mps2=np.zeros(3)) for t, q in zip(times, quats)]


def angle_deg(a, b):
    return math.degrees(math.acos(np.clip(np.dot(a, b), -1.0, 1.0)))


@pytest.mark.parametrize("theta_deg", [0.0, 35.0, 90.0, 180.0])
def test_known_quaternion_gives_known_normal(theta_deg):
    theta = math.radians(theta_deg)
    # R_x(theta) e_z = (0, -sin, cos); the outward normal is minus that.
    expected = np.array([0.0, math.sin(theta), -math.cos(theta)])
    np.testing.assert_allclose(face_normal_world(rotation_from_wxyz(quat_about_x(theta))), expected, atol=1e-12)
    times = np.arange(0.0, 0.3, 0.01)
    estimate = estimate_normal(readings(times, [quat_about_x(theta)] * len(times)), BASELINE)
    np.testing.assert_allclose(estimate.normal, expected, atol=1e-12)


def test_averaging_is_blind_to_quaternion_signs():
    rng = np.random.default_rng(0)
    truth = wxyz_from_rotation(Rotation.from_rotvec([0.3, -0.5, 1.1]))
    jitter = Rotation.from_rotvec(np.radians(0.5) * rng.standard_normal((40, 3)))
    quats = wxyz_from_rotation(rotation_from_wxyz(truth) * jitter)
    quats[::2] *= -1.0  # every other one in the opposite hemisphere
    assert np.linalg.norm(np.mean(quats, axis=0)) < 0.2  # a naive mean collapses
    mean = average_quaternion(quats)
    # For small jitter the mean orientation is the truth turned by the mean jitter rotation vector.
    expected = wxyz_from_rotation(rotation_from_wxyz(truth) * Rotation.from_rotvec(jitter.as_rotvec().mean(axis=0)))
    assert math.degrees(2 * math.acos(min(1.0, abs(np.dot(mean, expected))))) < 0.005
    # Symmetric about the identity: +-20 degrees about one axis average to exactly the identity.
    np.testing.assert_allclose(average_quaternion([quat_about_x(0.35), -quat_about_x(-0.35)]), [1, 0, 0, 0],
                               atol=1e-12)


def test_force_inversion_round_trips_the_pad_model():
    pad = PadResponse()
    times = np.arange(0.0, 0.3, 0.01)
    for force in (0.2, 1.0, 7.5):
        stream = readings(times, [quat_about_x(0.2)] * len(times), BASELINE + pad.pressure_rise_pa(force))
        estimate = estimate_normal(stream, BASELINE, pad=pad)
        assert estimate.force_n == pytest.approx(force, rel=1e-9)
        assert estimate.pressure_rise_pa == pytest.approx(pad.pressure_rise_pa(force), rel=1e-12)


def test_normal_waits_for_the_pad_to_settle():
    times = np.arange(0.0, 1.0, 0.01)
    final = math.radians(20.0)
    angles = np.minimum(times, 0.4) / 0.4 * final  # turning at 50 deg/s until t = 0.4 s
    estimate = estimate_normal(readings(times, [quat_about_x(a) for a in angles]), BASELINE)
    assert estimate.t_s > 0.4  # a 0.1 s window spans 5 degrees while turning: not steady
    np.testing.assert_allclose(estimate.normal, [0.0, math.sin(final), -math.cos(final)], atol=1e-9)


def test_unsettled_orientation_gives_a_clear_error():
    times = np.arange(0.0, 1.0, 0.01)
    spinning = readings(times, [quat_about_x(math.radians(30.0) * t) for t in times])  # 30 deg/s throughout
    with pytest.raises(OrientationNotSettledError, match="never settled"):
        estimate_normal(spinning, BASELINE)
    with pytest.raises(OrientationNotSettledError, match="no readings"):
        estimate_normal([], BASELINE)
    with pytest.raises(OrientationNotSettledError):  # too short to fill a settling window
        estimate_normal(readings(times[:5], [quat_about_x(0.0)] * 5), BASELINE)


def test_the_steadiest_window_is_read_where_the_first_would_catch_the_pad_turning():
    """A pad that turns slowly (4 deg/s) and then rests at 20 deg: a 1.5 deg test first passes while
    it turns, 1.2 s before it rests; the steadiest window is the resting one."""
    times = np.arange(0.0, 2.0, 0.01)
    rest = math.radians(20.0)
    angles = np.where(times < 1.5, rest - math.radians(4.0) * (1.5 - times), rest)
    stream = readings(times, [quat_about_x(a) for a in angles])
    loose = SettlingConfig(settle_window_s=0.15, max_deviation_rad=math.radians(1.5))
    expected = np.array([0.0, math.sin(rest), -math.cos(rest)])
    first = estimate_normal(stream, BASELINE, settling=loose)
    assert first.t_s < 0.5 and angle_deg(first.normal, expected) > 3.0
    steadiest = estimate_normal(stream, BASELINE, settling=replace(loose, window="steadiest"))
    assert steadiest.t_s >= 1.5 + 0.15 and steadiest.deviation_rad < 1e-9
    np.testing.assert_allclose(steadiest.normal, expected, atol=1e-9)
    with pytest.raises(ValueError, match="window must be one of first, steadiest"):
        SettlingConfig(window="last")


def test_mounting_and_reference_rotations_are_undone():
    body = Rotation.from_rotvec([0.4, -0.2, 0.9])
    mounting = Rotation.from_rotvec([0.0, 0.0, math.pi / 2])  # IMU turned 90 deg on its board
    reference = Rotation.from_rotvec([0.0, 0.0, 1.0])  # fusion heading 1 rad off the world's
    reported = reference.inv() * body * mounting.inv()
    alignment = ImuAlignment(body_in_imu_wxyz=tuple(wxyz_from_rotation(mounting)),
                             reference_in_world_wxyz=tuple(wxyz_from_rotation(reference)))
    times = np.arange(0.0, 0.3, 0.01)
    stream = readings(times, [wxyz_from_rotation(reported)] * len(times))
    estimate = estimate_normal(stream, BASELINE, alignment=alignment)
    np.testing.assert_allclose(estimate.normal, -body.apply([0.0, 0.0, 1.0]), atol=1e-12)
    assert angle_deg(estimate_normal(stream, BASELINE).normal, estimate.normal) > 10.0  # it mattered


def test_oriented_contact_puts_the_point_on_the_rotated_pad_face():
    times = np.arange(0.0, 0.3, 0.01)
    stream = readings(times, [quat_about_x(math.pi / 2)] * len(times))
    pivot = np.array([0.4, 0.1, 0.3])
    contact = oriented_contact(stream, pivot, [0.0, 0.0, 0.0277], BASELINE)
    assert isinstance(contact, OrientedContact)
    # R_x(90 deg) (0, 0, d) = (0, -d, 0)
    np.testing.assert_allclose(contact.position_m, pivot + [0.0, -0.0277, 0.0], atol=1e-12)
    np.testing.assert_allclose(contact.normal, [0.0, 1.0, 0.0], atol=1e-12)
    assert contact.force_n == pytest.approx(PadResponse().force_n(500.0))
    assert contact.readings == tuple(stream)
    with pytest.raises(ValueError, match="pivot_position_m"):
        oriented_contact(stream, [0.0, 0.0], [0.0, 0.0, 0.03], BASELINE)


def test_end_to_end_noisy_press_on_a_tilted_surface():
    """Simulated pad pressed on a plane tilted 20 deg: detector + estimator recover normal and force."""
    tilt = math.radians(20.0)
    surface_normal = np.array([0.0, math.sin(tilt), math.cos(tilt)])
    face_down = Rotation.from_rotvec([math.pi - tilt, 0.0, 0.0])  # pad +z into the surface
    np.testing.assert_allclose(-face_down.apply([0, 0, 1]), surface_normal, atol=1e-12)
    quat = wxyz_from_rotation(face_down)
    # mounting misalignment off: a calibrated sensor (ImuAlignment removes it on hardware)
    calibrated = BNO055Config(noise=replace(BNO055Noise(), mounting_misalignment_std_rad=0.0))
    sensor = SimulatedTactileSensor(config=SimulatedSensorConfig(imu=calibrated), seed=11)
    detector = PressureContactDetector()
    contact_readings, start = [], None
    with sensor:
        for t in np.arange(0.0, 3.0, 1.0 / 240.0):
            force = 1.2 if 1.0 <= t < 2.0 else 0.0
            sensor.on_step(PadState(t, np.zeros(3), quat, np.zeros(3), np.zeros(3), force))
            for r in sensor.drain():
                event = detector.update(r)
                start = event if event is not None and event.kind == "start" else start
                if detector.in_contact:
                    contact_readings.append(r)
    estimate = estimate_normal(contact_readings, start.baseline_pa)
    assert angle_deg(estimate.normal, surface_normal) < 1.0  # BNO055 tilt bias ~0.12 deg RMS per axis
    assert estimate.force_n == pytest.approx(1.2, abs=0.02)
