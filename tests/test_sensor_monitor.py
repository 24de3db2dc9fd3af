"""sensor-monitor: contact state, compensated pressure and orientation on live readings, recording, the CLI."""
from __future__ import annotations

import csv
import io
import json
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from explorer.session import read_session
from scripts.sensor_monitor import main
from sensor.calibration import SensorCalibration
from sensor.emulated_fingertip import PressScript, emulated_fingertip
from sensor.emulators import FakeClock
from sensor.interface import TactileSensor
from explorer.monitor import CSV_COLUMNS, CsvRecorder, SensorMonitor, SessionRecorder, format_sample, run_monitor
from sensor.normal_estimation import ImuAlignment
from sensor.reading import Reading
from common.rotations import rotation_from_wxyz, wxyz_from_rotation

MOUNTING = Rotation.from_rotvec(np.radians([1.5, -2.0, 0.0]))


def _rig(n_presses=3, **options):
    script = PressScript.regular(n_presses, quiet_s=1.0, body_in_imu_wxyz=tuple(wxyz_from_rotation(MOUNTING)),
                                 **options)
    clock = FakeClock(50.0)
    return script, emulated_fingertip(script, clock=clock.monotonic, sleep=clock.sleep), clock


def _samples(monitor, clock, until_s):
    samples = []
    while clock.now < until_s:
        clock.sleep(0.01)
        samples += monitor.poll()
    return samples


def test_contacts_and_compensated_pressure_follow_the_presses():
    script, sensor, clock = _rig()
    with sensor:
        monitor = SensorMonitor(sensor)
        samples = _samples(monitor, clock, 50.0 + script.end_s)
    events = [s.event for s in samples if s.event is not None]
    assert [e.kind for e in events] == ["start", "end"] * 3
    t0 = samples[0].reading.t_s
    for press, start in zip(script.presses, events[::2]):
        assert start.onset_t_s - t0 == pytest.approx(press.start_s, abs=0.03)
    pressed = [s for s in samples if s.in_contact and s.reading.t_s - t0 > script.presses[0].start_s + 0.1
               and s.reading.t_s - t0 < script.presses[0].end_s - 0.1]
    free = [s for s in samples if not s.in_contact]
    assert np.mean([s.rise_pa for s in pressed]) == pytest.approx(script.presses[0].rise_pa, abs=15.0)
    assert max(abs(s.rise_pa) for s in free[:50]) < 15.0  # drift removed: only noise is left
    assert monitor.n_contacts == 3 and monitor.n_readings == len(samples)


def test_face_normal_uses_the_alignment():
    script, sensor, clock = _rig(n_presses=1)
    with sensor:
        raw = SensorMonitor(sensor)
        samples = _samples(raw, clock, 50.0 + script.presses[0].start_s + 0.4)
    pressed = samples[-1]
    assert pressed.in_contact
    assert pressed.tilt_deg == pytest.approx(math.degrees(MOUNTING.magnitude()), abs=1.0)
    aligned = SensorMonitor(sensor, alignment=ImuAlignment(body_in_imu_wxyz=tuple(wxyz_from_rotation(MOUNTING))))
    corrected = aligned.process(pressed.reading)
    assert corrected.tilt_deg < 1.0  # the press's residual tilt only
    expected = -rotation_from_wxyz(pressed.reading.quat_wxyz).apply([0.0, 0.0, 1.0])
    np.testing.assert_allclose(pressed.face_normal, expected, atol=1e-12)


class ListSensor(TactileSensor):
    """Any TactileSensor works: here a list of readings handed out one per drain."""

    def __init__(self, readings):
        self.readings = list(readings)

    def read(self):
        return self.readings[0]

    def drain(self):
        return [self.readings.pop(0)] if self.readings else []


def _reading(t, pressure):
    return Reading(t_s=t, pressure_pa=pressure, quat_wxyz=np.array([1.0, 0.0, 0.0, 0.0]),
                   lin_acc_mps2=np.zeros(3), gravity_mps2=np.array([0.0, 0.0, 9.8]), temperature_c=24.5)


def test_any_tactile_sensor_can_be_monitored_and_recorded_to_csv(tmp_path):
    readings = [_reading(0.01 * i, 1e5 + (400.0 if 20 <= i < 40 else 0.0)) for i in range(60)]
    monitor = SensorMonitor(ListSensor(readings), recorders=[CsvRecorder(tmp_path / "m.csv")])
    clock = FakeClock()
    out = io.StringIO()
    summary = run_monitor(monitor, 0.6, display_hz=10, poll_hz=100, out=out, clock=clock.monotonic, sleep=clock.sleep)
    assert summary.n_readings == 60 and summary.n_contacts == 1
    lines = out.getvalue().splitlines()
    assert sum(line.startswith("** contact start at 0.2") for line in lines) == 1
    assert sum(line.startswith("** contact end at 0.4") for line in lines) == 1
    assert 5 <= sum(line.startswith("t ") for line in lines) <= 7  # 10 lines per second for 0.6 s
    with open(tmp_path / "m.csv", newline="") as file:
        rows = list(csv.reader(file))
    assert tuple(rows[0]) == CSV_COLUMNS and len(rows) == 61
    table = np.array(rows[1:], dtype=float)
    np.testing.assert_array_equal(table[:, 0], [r.t_s for r in readings])
    np.testing.assert_array_equal(table[:, 1], [r.pressure_pa for r in readings])
    assert table[20:40, 4].sum() >= 15 and table[:19, 4].sum() == 0  # in_contact column
    np.testing.assert_allclose(table[:, 3], table[:, 1] - table[:, 2])  # rise = pressure - baseline
    np.testing.assert_allclose(table[:, 9:12], np.tile([0.0, 0.0, -1.0], (60, 1)), atol=1e-12)  # z up: face down


def test_format_sample_shows_the_numbers():
    monitor = SensorMonitor(ListSensor([_reading(5.0, 100_000.0), _reading(5.5, 100_350.0)]))
    monitor.poll()
    sample = monitor.poll()[0]
    text = format_sample(sample, t0_s=5.0)
    assert text.startswith("t    0.500 s") and "p   100350.0 Pa" in text and "dp   +350.0 Pa" in text
    assert "n (+0.000 +0.000 -1.000)" in text and "tilt 180.0 deg" in text


def test_session_recording_can_be_read_back(tmp_path):
    script, sensor, clock = _rig(n_presses=2)
    with sensor:
        monitor = SensorMonitor(sensor, recorders=[SessionRecorder(tmp_path / "session", "emulated")])
        run_monitor(monitor, script.end_s, out=None, clock=clock.monotonic, sleep=clock.sleep)
    session = read_session(tmp_path / "session")
    assert len(session.readings) == monitor.n_readings
    kinds = [event.kind for event in session.events]
    assert kinds == ["contact_start", "contact_end"] * 2


def test_run_monitor_rejects_bad_durations():
    monitor = SensorMonitor(ListSensor([]))
    for duration in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match="duration_s"):
            run_monitor(monitor, duration)


# ---- the command ---------------------------------------------------------------------------

def test_cli_emulate_monitors_and_writes_csv(tmp_path):
    clock = FakeClock()
    out = io.StringIO()
    status = main(["--emulate", "--duration", "6", "--rate", "2", "--quiet-s", "1", "--csv", str(tmp_path / "m.csv")],
                  clock=clock.monotonic, sleep=clock.sleep, out=out)
    text = out.getvalue()
    assert status == 0
    assert "** contact start" in text and "** contact end" in text
    assert 11 <= sum(line.startswith("t ") for line in text.splitlines()) <= 13  # 2 lines/s for 6 s
    summary = text.strip().splitlines()[-1]
    assert summary.endswith("in 6.0 s") and "contacts" in summary
    assert (tmp_path / "m.csv").read_text().count("\n") > 500


def test_cli_calibrate_recovers_the_emulated_mounting(tmp_path):
    clock = FakeClock()
    out = io.StringIO()
    path = tmp_path / "cal.json"
    status = main(["--emulate", "--calibrate", str(path), "--presses", "4", "--emulate-tilt-deg", "2.5", "1.0"],
                  clock=clock.monotonic, sleep=clock.sleep, out=out)
    assert status == 0, out.getvalue()
    calibration = SensorCalibration.load(path)
    truth = Rotation.from_rotvec(np.radians([2.5, 1.0, 0.0]))
    error = math.degrees((rotation_from_wxyz(calibration.mounting.body_in_imu_wxyz) * truth.inv()).magnitude())
    assert error < 0.5
    assert "press 4/4" in out.getvalue() and f"wrote {path}" in out.getvalue()
    assert json.loads(path.read_text())["imu_alignment"]["n_presses"] == 4


def test_cli_uses_the_calibration_of_the_config(tmp_path):
    SensorCalibration(bno055_profile_hex=None).save(tmp_path / "cal.json")
    config = tmp_path / "c.toml"
    config.write_text('[sensor]\nbackend = "emulated"\ncalibration = "cal.json"\n')
    clock = FakeClock()
    out = io.StringIO()
    assert main(["--config", str(config), "--duration", "1"], clock=clock.monotonic, sleep=clock.sleep, out=out) == 0
    assert out.getvalue().startswith("sensor: emulated")


@pytest.mark.parametrize("content, message", [
    ('[sensor]\nbackend = "sim"\n', "no live sensor to monitor"),
    ('[sensor]\nbackend = "emulated"\ncalibration = "missing.json"\n', "missing.json"),
    ('[sensor]\nbackend = "i2c"\nbus = 99\n', ""),
])
def test_cli_errors_are_reported_with_exit_status_1(tmp_path, capsys, content, message):
    config = tmp_path / "c.toml"
    config.write_text(content)
    status = main(["--config", str(config), "--duration", "1"], out=io.StringIO())
    assert status == 1
    error = capsys.readouterr().err
    assert error.startswith("sensor-monitor: error: ") and message in error


def test_cli_needs_a_sensor_source(capsys):
    with pytest.raises(SystemExit) as info:
        main([])
    assert info.value.code == 2
    assert "--config" in capsys.readouterr().err


def test_cli_calibrate_works_before_the_configured_calibration_file_exists(tmp_path):
    """The documented first step: the config names the file that --calibrate is about to write."""
    config = tmp_path / "c.toml"
    config.write_text('[sensor]\nbackend = "emulated"\ncalibration = "calibration.json"\n')
    clock = FakeClock()
    out = io.StringIO()
    status = main(["--config", str(config), "--calibrate", str(tmp_path / "calibration.json"), "--presses", "3"],
                  clock=clock.monotonic, sleep=clock.sleep, out=out)
    assert status == 0, out.getvalue()
    assert SensorCalibration.load(tmp_path / "calibration.json").mounting.n_presses == 3
