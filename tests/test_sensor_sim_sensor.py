"""SimulatedTactileSensor: lifecycle, per-chip rates with sample-and-hold, validation, end to end."""
import math

import numpy as np
import pytest

from sensor.contact_detection import PressureContactDetector
from common.pad_state import PadState
from sensor.sim_sensor import NoReadingError, SensorNotOpenError, SimulatedSensorConfig, SimulatedTactileSensor

DT = 1.0 / 240.0
IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


def pad_state(t_s, force_n=0.0, quat=IDENTITY, **overrides):
    fields = dict(t_s=t_s, position_m=np.zeros(3), quat_wxyz=np.asarray(quat, float), lin_vel_mps=np.zeros(3),
                  ang_vel_radps=np.zeros(3), normal_force_n=force_n)
    fields.update(overrides)
    return PadState(**fields)


def spinning(t_s):
    """Rotating about z at 1 rad/s, pressed harder and harder: every chip sample differs from the last."""
    return pad_state(t_s, force_n=0.5 * t_s, quat=[math.cos(t_s / 2), 0.0, 0.0, math.sin(t_s / 2)])


def test_reading_before_open_or_after_close_is_refused():
    sensor = SimulatedTactileSensor(seed=0)
    with pytest.raises(SensorNotOpenError, match="open"):
        sensor.read()
    with pytest.raises(SensorNotOpenError):
        sensor.drain()
    with sensor:
        with pytest.raises(NoReadingError, match="on_step"):
            sensor.read()
        sensor.on_step(pad_state(0.0))
        assert sensor.read().t_s == 0.0
    with pytest.raises(SensorNotOpenError):
        sensor.read()


def test_each_chip_samples_at_its_own_rate_and_the_other_channels_hold():
    sensor = SimulatedTactileSensor(config=SimulatedSensorConfig().noiseless(), seed=0)
    sensor.open()
    step_times = np.arange(0.0, 2.0, DT)
    for t in step_times:
        sensor.on_step(spinning(t))
    readings = sensor.drain()
    times = np.array([r.t_s for r in readings])
    assert np.all(np.diff(times) > 0.0)
    assert np.all(np.min(np.abs(times[:, None] - step_times[None, :]), axis=1) < 1e-12)  # stamped at steps
    pressure_updates = 1 + np.count_nonzero(np.diff([r.pressure_pa for r in readings]))
    imu_updates = 1 + np.count_nonzero(np.any(np.diff([r.quat_wxyz for r in readings], axis=0), axis=1))
    period_bmp = sensor.config.barometer.sample_period_s
    assert pressure_updates == math.floor(2.0 / period_bmp) + 1  # 83.3 Hz (x4 oversampling)
    assert imu_updates == 200  # 100 Hz fusion rate
    assert len(readings) < pressure_updates + imu_updates  # coinciding samples share one reading
    assert len(readings) >= max(pressure_updates, imu_updates)
    assert sensor.drain() == []


def test_read_returns_the_newest_and_drain_everything_since_the_last_drain():
    sensor = SimulatedTactileSensor(seed=1)
    sensor.open()
    for t in np.arange(0.0, 0.5, DT):
        sensor.on_step(pad_state(t))
    newest = sensor.read()
    first = sensor.drain()
    assert first[-1] is newest
    for t in np.arange(0.5, 0.6, DT):
        sensor.on_step(pad_state(t))
    second = sensor.drain()
    assert second and second[0].t_s > first[-1].t_s


def test_noiseless_press_reads_ambient_plus_the_pad_curve():
    config = SimulatedSensorConfig().noiseless()
    sensor = SimulatedTactileSensor(config=config, seed=0)
    sensor.open()
    for t in np.arange(0.0, 1.0, DT):
        sensor.on_step(pad_state(t, force_n=1.0 if t >= 0.5 else 0.0))
    barometer = config.barometer
    rise = sensor.read().pressure_pa - barometer.ambient_pressure_pa
    assert rise == pytest.approx(barometer.pad.pressure_rise_pa(1.0), abs=barometer.resolution_pa)
    np.testing.assert_allclose(sensor.read().gravity_mps2, [0.0, 0.0, 9.81], atol=0.005)


def test_steps_while_closed_are_ignored_and_reopening_starts_afresh():
    sensor = SimulatedTactileSensor(seed=2)
    sensor.on_step(pad_state(0.0))  # closed: nothing happens
    sensor.open()
    with pytest.raises(NoReadingError):
        sensor.read()
    sensor.on_step(pad_state(1.0))
    sensor.close()
    sensor.on_step(pad_state(2.0))
    sensor.open()
    sensor.on_step(pad_state(0.5))  # a fresh power-on accepts a new clock
    assert [r.t_s for r in sensor.drain()] == [0.5]


def test_pull_mode_fetches_the_source_state_once_per_new_time():
    clock = {"t": 0.0}
    sensor = SimulatedTactileSensor(pad_state_source=lambda: pad_state(clock["t"]), seed=3)
    with sensor:
        assert sensor.read().t_s == 0.0
        assert sensor.read().t_s == 0.0
        clock["t"] = 0.05
        assert sensor.read().t_s == 0.05
        assert [r.t_s for r in sensor.drain()] == [0.0, 0.05]


@pytest.mark.parametrize("state, word", [
    (pad_state(0.0), "increase"),
    (pad_state(1.0, quat=[1.0, 0.1, 0.0, 0.0]), "unit quaternion"),
    (pad_state(1.0, force_n=-0.2), "normal_force_n"),
    (pad_state(1.0, lin_vel_mps=np.array([0.0, np.nan, 0.0])), "lin_vel_mps"),
    (pad_state(float("nan")), "finite"),
])
def test_malformed_pad_states_are_refused_by_name(state, word):
    sensor = SimulatedTactileSensor(seed=0)
    sensor.open()
    sensor.on_step(pad_state(0.0))
    with pytest.raises(ValueError, match=word):
        sensor.on_step(state)


def test_a_full_buffer_warns_and_counts_what_it_discards():
    sensor = SimulatedTactileSensor(seed=0, buffer_size=10)
    sensor.open()
    with pytest.warns(RuntimeWarning, match="drain"):
        for k in range(15):
            sensor.on_step(pad_state(0.01 * k))  # every step yields an IMU sample
    assert len(sensor.drain()) == 10
    assert sensor.discarded_readings == 5


def test_seed_makes_the_whole_sensor_repeatable():
    def stream(seed):
        sensor = SimulatedTactileSensor(seed=seed)
        sensor.open()
        for t in np.arange(0.0, 0.3, DT):
            sensor.on_step(pad_state(t))
        return [(r.pressure_pa, tuple(r.quat_wxyz)) for r in sensor.drain()]

    assert stream(7) == stream(7) and stream(7) != stream(8)


def test_simulated_press_is_detected_soon_after_the_force_reaches_the_threshold_level():
    sensor = SimulatedTactileSensor(seed=4)
    detector = PressureContactDetector()
    ramp_start, ramp_rate = 3.0, 2.0  # N/s, pressed for 1 s, then released
    events = []
    with sensor:
        for t in np.arange(0.0, 6.0, DT):
            force = ramp_rate * (t - ramp_start) if ramp_start <= t < ramp_start + 1.0 else 0.0
            sensor.on_step(pad_state(t, force_n=force))
            events += detector.process(sensor.drain())
    assert [e.kind for e in events] == ["start", "end"]
    pad = sensor.config.barometer.pad
    threshold_force = pad.force_n(detector.config.start_threshold_pa)
    crossing = ramp_start + threshold_force / ramp_rate
    # Lag (20 ms) + minimum duration (20 ms) + one barometer period (12 ms) + noise margin.
    assert crossing < events[0].t_s < crossing + 0.07
    assert ramp_start + 1.0 < events[1].t_s < ramp_start + 1.1
