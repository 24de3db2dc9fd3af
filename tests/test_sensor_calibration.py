"""Calibration: pressure baseline statistics, IMU mounting from presses, file round trip, emulated end to end."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from sensor.calibration import (PressureBaseline, SensorCalibration, calibrate,
                                estimate_imu_mounting, find_presses, measure_pressure_baseline,
                                record_calibration)
from sensor.emulated_fingertip import PressScript, emulated_fingertip
from sensor.emulators import FakeClock
from sensor.normal_estimation import ImuAlignment
from sensor.reading import Reading
from common.rotations import rotation_from_wxyz, wxyz_from_rotation

FLAT = Rotation.from_rotvec([math.pi, 0.0, 0.0])  # body +z down: pressed on a table


def _reading(t_s, pressure_pa, quat=(1.0, 0.0, 0.0, 0.0)):
    return Reading(t_s=t_s, pressure_pa=pressure_pa, quat_wxyz=np.asarray(quat, float),
                   lin_acc_mps2=np.zeros(3), gravity_mps2=np.array([0.0, 0.0, 9.81]))


def _angle_deg(a: Rotation, b: Rotation) -> float:
    return math.degrees((a * b.inv()).magnitude())


# ---- pressure baseline ---------------------------------------------------------------------

def test_baseline_of_an_exact_line_has_its_slope_and_no_noise():
    t = np.linspace(0.0, 2.0, 201)
    baseline = measure_pressure_baseline([_reading(ti, 101000.0 + 0.75 * ti) for ti in t])
    assert baseline.mean_pa == pytest.approx(101000.75, abs=1e-9)
    assert baseline.drift_pa_per_s == pytest.approx(0.75, abs=1e-9)
    assert baseline.noise_std_pa == pytest.approx(0.0, abs=1e-6)
    assert baseline.n_readings == 201 and baseline.duration_s == pytest.approx(2.0)


def test_baseline_noise_and_drift_match_the_generating_values_within_their_sampling_error():
    rng = np.random.default_rng(3)
    t = np.arange(2000) * 0.01
    sigma, drift = 2.0, -0.4
    pressures = 100500.0 + drift * t + rng.normal(0.0, sigma, t.size)
    baseline = measure_pressure_baseline([_reading(ti, p) for ti, p in zip(t, pressures)])
    slope_error = sigma / math.sqrt(np.sum((t - t.mean()) ** 2))  # standard error of a fitted slope
    assert baseline.drift_pa_per_s == pytest.approx(drift, abs=4 * slope_error)
    assert baseline.noise_std_pa == pytest.approx(sigma, rel=4 / math.sqrt(2 * t.size))
    assert baseline.mean_pa == pytest.approx(100500.0 + drift * t.mean(), abs=4 * sigma / math.sqrt(t.size))


@pytest.mark.parametrize("times, message", [
    (np.arange(5) * 0.01, "at least 20 readings"),
    (np.r_[np.arange(30) * 0.01, 0.1], "strictly increasing"),
])
def test_baseline_rejects_bad_input(times, message):
    with pytest.raises(ValueError, match=message):
        measure_pressure_baseline([_reading(t, 1e5) for t in times])


# ---- mounting offset -----------------------------------------------------------------------

def _press_quats(mounting: Rotation, yaws_deg, tilts_deg=None, reference=Rotation.identity()):
    """Reported quaternions for presses flat on a level table at the given yaws."""
    quats = []
    for i, yaw in enumerate(yaws_deg):
        body = Rotation.from_rotvec([0.0, 0.0, math.radians(yaw)]) * FLAT
        if tilts_deg is not None:
            body = Rotation.from_rotvec(np.radians(tilts_deg[i])) * body
        quats.append(wxyz_from_rotation(reference.inv() * body * mounting.inv()))
    return np.array(quats)


def test_a_pure_tilt_mounting_is_recovered_exactly():
    mounting = Rotation.from_rotvec(np.radians([2.0, -3.0, 0.0]))
    estimate = estimate_imu_mounting(_press_quats(mounting, [0, 70, 150, 230, 300]))
    assert _angle_deg(rotation_from_wxyz(estimate.body_in_imu_wxyz), mounting) < 1e-7
    assert math.degrees(estimate.tilt_rad) == pytest.approx(math.degrees(mounting.magnitude()), abs=1e-7)
    assert estimate.spread_rad < 1e-9 and estimate.n_presses == 5


def test_rotation_about_the_face_normal_is_unobservable_and_does_not_change_normals():
    mounting = Rotation.from_rotvec(np.radians([0.0, 0.0, 25.0])) * Rotation.from_rotvec(np.radians([1.0, 2.5, 0.0]))
    quats = _press_quats(mounting, [10, 100, 200])
    estimate = estimate_imu_mounting(quats)
    np.testing.assert_allclose(estimate.face_axis_in_imu, mounting.apply([0.0, 0.0, 1.0]), atol=1e-12)
    alignment = ImuAlignment(body_in_imu_wxyz=tuple(estimate.body_in_imu_wxyz))
    for quat in quats:
        outward = -alignment.body_rotation(quat).apply([0.0, 0.0, 1.0])
        np.testing.assert_allclose(outward, [0.0, 0.0, 1.0], atol=1e-12)


def test_a_tilted_fusion_reference_frame_is_taken_into_account():
    mounting = Rotation.from_rotvec(np.radians([-1.0, 1.5, 0.0]))
    reference = Rotation.from_rotvec(np.radians([3.0, 0.0, 40.0]))
    quats = _press_quats(mounting, [0, 120, 240], reference=reference)
    estimate = estimate_imu_mounting(quats, reference_in_world_wxyz=wxyz_from_rotation(reference))
    assert _angle_deg(rotation_from_wxyz(estimate.body_in_imu_wxyz), mounting) < 1e-7


def test_averaging_presses_reduces_random_alignment_errors():
    rng = np.random.default_rng(0)
    mounting = Rotation.from_rotvec(np.radians([2.0, 1.0, 0.0]))
    n = 40
    tilts = np.c_[rng.normal(0.0, 0.5, (n, 2)), np.zeros(n)]  # 0.5 deg residual per press
    estimate = estimate_imu_mounting(_press_quats(mounting, rng.uniform(0, 360, n), tilts))
    assert _angle_deg(rotation_from_wxyz(estimate.body_in_imu_wxyz), mounting) < 4 * 0.5 / math.sqrt(n)


def test_presses_that_disagree_are_refused():
    quats = _press_quats(Rotation.identity(), [0, 90, 180], tilts_deg=[(0, 0, 0), (0, 0, 0), (5.0, 0, 0)])
    with pytest.raises(ValueError, match=r"disagree.*deg from their mean.*level"):
        estimate_imu_mounting(quats)


@pytest.mark.parametrize("quats, message", [
    (np.zeros((0, 4)), "n >= 1"),
    (np.ones((2, 3)), r"\(n, 4\)"),
    (np.full((2, 4), 0.9), "unit quaternions"),
])
def test_mounting_rejects_bad_input(quats, message):
    with pytest.raises(ValueError, match=message):
        estimate_imu_mounting(quats)


# ---- calibration file ----------------------------------------------------------------------

def _calibration():
    mounting = estimate_imu_mounting(_press_quats(Rotation.from_rotvec(np.radians([1.0, -2.0, 0.0])), [0, 90, 200]))
    return SensorCalibration(PressureBaseline(100900.5, 2.1, 0.3, 200, 1.99), mounting,
                             bno055_profile_hex="00" * 22)


def test_calibration_file_round_trip(tmp_path):
    calibration = _calibration()
    loaded = SensorCalibration.load(calibration.save(tmp_path / "cal.json"))
    assert loaded.pressure_baseline == calibration.pressure_baseline
    np.testing.assert_allclose(loaded.mounting.body_in_imu_wxyz, calibration.mounting.body_in_imu_wxyz, atol=1e-15)
    assert loaded.mounting.tilt_rad == pytest.approx(calibration.mounting.tilt_rad, abs=1e-12)
    assert loaded.imu_alignment() == calibration.imu_alignment()
    assert loaded.bno055_profile_hex == "00" * 22
    assert json.loads((tmp_path / "cal.json").read_text())["format"] == "tactile-sensor-calibration"


def test_a_hand_written_file_with_only_the_quaternion_loads(tmp_path):
    quat = wxyz_from_rotation(Rotation.from_rotvec(np.radians([0.0, 2.0, 0.0])))
    path = tmp_path / "cal.json"
    path.write_text(json.dumps({"format": "tactile-sensor-calibration", "version": 1, "imu_alignment": {
        "body_in_imu_wxyz": list(quat), "reference_in_world_wxyz": [1, 0, 0, 0]}}))
    loaded = SensorCalibration.load(path)
    assert math.degrees(loaded.mounting.tilt_rad) == pytest.approx(2.0, abs=1e-9)
    assert loaded.pressure_baseline is None


@pytest.mark.parametrize("content, message", [
    ("{", "not valid JSON"),
    ('{"format": "other"}', "not a sensor calibration file"),
    ('{"format": "tactile-sensor-calibration", "version": 9}', "version 9"),
    ('{"format": "tactile-sensor-calibration", "version": 1, "imu_alignment": '
     '{"body_in_imu_wxyz": [1, 1, 0, 0], "reference_in_world_wxyz": [1, 0, 0, 0]}}', "body_in_imu_wxyz"),
    ('{"format": "tactile-sensor-calibration", "version": 1}', "imu_alignment"),
])
def test_bad_calibration_files_name_the_problem(tmp_path, content, message):
    path = tmp_path / "cal.json"
    path.write_text(content)
    with pytest.raises(ValueError, match=message) as info:
        SensorCalibration.load(path)
    assert str(path) in str(info.value)


def test_a_missing_calibration_file_is_named(tmp_path):
    with pytest.raises(FileNotFoundError, match="nothing.json"):
        SensorCalibration.load(tmp_path / "nothing.json")


# ---- end to end on the emulated fingertip --------------------------------------------------

TRUE_MOUNTING = Rotation.from_rotvec(np.radians([2.0, -3.0, 0.0]))


def _emulated(n_presses=5, seed=1, **options):
    script = PressScript.regular(n_presses, quiet_s=2.5, body_in_imu_wxyz=tuple(wxyz_from_rotation(TRUE_MOUNTING)),
                                 seed=seed, **options)
    clock = FakeClock(100.0)
    return script, emulated_fingertip(script, clock=clock.monotonic, sleep=clock.sleep), clock


def test_record_calibration_recovers_the_injected_mounting_offset():
    script, sensor, clock = _emulated()
    with sensor:
        calibration, presses = record_calibration(sensor, quiet_s=2.0, n_presses=5, clock=clock.monotonic,
                                                  sleep=clock.sleep)
    assert len(presses.quats_wxyz) == 5 and presses.skipped == ()
    error = _angle_deg(rotation_from_wxyz(calibration.mounting.body_in_imu_wxyz), TRUE_MOUNTING)
    assert error < 0.5
    baseline = calibration.pressure_baseline
    assert baseline.mean_pa == pytest.approx(script.baseline_pa + script.drift_pa_per_s * 1.0, abs=1.0)
    assert baseline.noise_std_pa == pytest.approx(script.noise_pa, rel=0.3)  # plus BMP280 quantisation


def test_the_calibrated_alignment_corrects_the_normals_of_new_presses():
    script, sensor, clock = _emulated(n_presses=8, seed=4)
    with sensor:
        calibration, _ = record_calibration(sensor, quiet_s=2.0, n_presses=5, clock=clock.monotonic,
                                            sleep=clock.sleep)
        later = []
        while clock.now < 100.0 + script.end_s:
            clock.sleep(0.01)
            later += sensor.drain()
    presses = find_presses(later)
    assert len(presses.quats_wxyz) >= 2
    for quat in presses.quats_wxyz:
        raw = -rotation_from_wxyz(quat).apply([0.0, 0.0, 1.0])
        corrected = -calibration.imu_alignment().body_rotation(quat).apply([0.0, 0.0, 1.0])
        assert math.degrees(math.acos(raw[2])) > 3.0  # uncorrected: off by about the mounting tilt
        assert math.degrees(math.acos(corrected[2])) < 1.5  # corrected: only the press's residual tilt


def test_record_calibration_gives_up_when_nobody_presses():
    script, sensor, clock = _emulated(n_presses=0)
    with sensor, pytest.raises(ValueError, match="only 0 of 3 presses within 5 s"):
        record_calibration(sensor, quiet_s=1.0, n_presses=3, timeout_s=5.0, clock=clock.monotonic, sleep=clock.sleep)


def test_calibrate_needs_enough_settled_presses():
    script, sensor, clock = _emulated(n_presses=2)
    readings = []
    with sensor:
        while clock.now < 100.0 + script.end_s:
            clock.sleep(0.01)
            readings += sensor.drain()
    quiet = [r for r in readings if r.t_s < readings[0].t_s + 2.0]
    with pytest.raises(ValueError, match="found 2 usable presses, need 3"):
        calibrate(quiet, readings, min_presses=3)


def test_a_press_that_never_settles_is_reported_not_dropped():
    t = np.arange(0.0, 1.0, 0.01)
    readings = [_reading(ti, 1e5) for ti in t[:20]]
    for i, ti in enumerate(t[20:70]):  # pressed, but the orientation keeps turning
        readings.append(_reading(ti, 1e5 + 800, wxyz_from_rotation(Rotation.from_rotvec([0.0, 0.0, 0.1 * i]))))
    readings += [_reading(ti, 1e5) for ti in t[70:]]
    presses = find_presses(readings)
    assert len(presses.quats_wxyz) == 0
    assert len(presses.skipped) == 1 and "never settled" in presses.skipped[0]
