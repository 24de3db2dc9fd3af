"""Contact detectors on synthetic reading streams."""
import math

import numpy as np
import pytest

from sensor.contact_detection import (AccelerationSpikeDetector, OrientationChangeDetector, PressureContactDetector,
                                      PressureDetectorConfig)
from common.pad_state import PadState
from sensor.reading import Reading
from sensor.sim.bmp280 import BMP280Config, SimulatedBMP280

PERIOD = 0.012  # BMP280 x4 oversampling, normal mode
AMBIENT = 101325.0
IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


def reading(t_s, pressure_pa=AMBIENT, quat=IDENTITY, lin_acc=(0.0, 0.0, 0.0)):
    return Reading(t_s=t_s, pressure_pa=pressure_pa, quat_wxyz=np.asarray(quat, float),
                   lin_acc_mps2=np.asarray(lin_acc, float), gravity_mps2=np.array([0.0, 0.0, 9.81]))


def pressure_stream(times, pressures):
    return [reading(t, p) for t, p in zip(times, pressures)]


# --- pressure detector -------------------------------------------------------------------------

def test_drift_alone_never_triggers():
    rng = np.random.default_rng(0)
    times = np.arange(0.0, 1800.0, PERIOD)  # 30 min
    # Ten times the default random walk, a 1.8 kPa/h trend and data-sheet white noise.
    walk = np.cumsum(4.0 * math.sqrt(PERIOD) * rng.standard_normal(len(times)))
    pressures = AMBIENT + walk + 1.0 * times + 2.1 * rng.standard_normal(len(times))
    assert np.ptp(pressures) > 300.0  # the drift is far larger than the threshold
    assert PressureContactDetector().process(pressure_stream(times, pressures)) == []


def test_datasheet_noise_gives_no_false_contact_over_a_long_free_stream():
    config = BMP280Config(oversampling=1)  # the noisiest setting, 3.3 Pa RMS, plus default drift
    chip = SimulatedBMP280(config, np.random.default_rng(1))
    free_pad = [PadState(t, np.zeros(3), IDENTITY, np.zeros(3), np.zeros(3), 0.0)
                for t in np.arange(0.0, 600.0, config.sample_period_s)]
    readings = [reading(s.t_s, s.pressure_pa) for s in map(chip.step, free_pad)]
    detector = PressureContactDetector()
    assert detector.process(readings) == []
    assert not detector.in_contact


def test_step_of_150_pa_starts_a_contact_after_the_minimum_duration():
    times = np.arange(0.0, 3.0, PERIOD)
    step_t = times[150]
    detector = PressureContactDetector()
    events = detector.process(pressure_stream(times, np.where(times >= step_t, AMBIENT + 150.0, AMBIENT)))
    assert len(events) == 1
    (start,) = events
    assert start.kind == "start" and detector.in_contact
    assert start.onset_t_s == step_t
    min_duration = detector.config.min_start_duration_s
    assert step_t + min_duration <= start.t_s < step_t + min_duration + PERIOD
    assert start.baseline_pa == pytest.approx(AMBIENT)
    assert start.signal == pytest.approx(150.0)


def test_blip_shorter_than_the_minimum_duration_is_ignored_and_leaves_the_baseline_alone():
    times = np.arange(0.0, 2.0, PERIOD)
    blip = (times >= 1.0) & (times < 1.0 + PERIOD)  # one sample of +500 Pa
    detector = PressureContactDetector()
    assert detector.process(pressure_stream(times, np.where(blip, AMBIENT + 500.0, AMBIENT))) == []
    assert detector.baseline_pa == pytest.approx(AMBIENT)


def test_hysteresis_ends_only_below_the_lower_threshold():
    times = np.arange(0.0, 4.0, PERIOD)
    levels = np.select([times < 1.0, times < 2.0, times < 3.0], [0.0, 150.0, 80.0], 30.0)
    detector = PressureContactDetector()
    events = detector.process(pressure_stream(times, AMBIENT + levels))
    assert [e.kind for e in events] == ["start", "end"]
    end_onset = times[np.argmax(times >= 3.0)]
    assert events[1].onset_t_s == end_onset  # 80 Pa (between the thresholds) kept the contact
    assert end_onset + detector.config.min_end_duration_s <= events[1].t_s < end_onset + 0.01 + PERIOD
    assert not detector.in_contact


def test_baseline_freezes_during_contact_and_tracks_again_when_free():
    times = np.arange(0.0, 18.0, PERIOD)
    drift = 2.0 * times  # 2 Pa/s
    contact = (times >= 2.0) & (times < 6.0)
    pressures = AMBIENT + drift + np.where(contact, 400.0 + 50.0 * np.sin(times), 0.0)
    detector = PressureContactDetector()
    baselines = []
    for r in pressure_stream(times, pressures):
        detector.update(r)
        baselines.append(detector.baseline_pa)
    baselines = np.array(baselines)
    during = baselines[(times > 2.1) & (times < 6.0)]
    assert np.ptp(during) == 0.0  # frozen although the pressure keeps moving
    after = baselines[times > 17.0]  # 5 time constants after the release
    # An EMA tracking a ramp lags it by rate * tau = 2 Pa/s * 2 s.
    tau = detector.config.baseline_time_constant_s
    np.testing.assert_allclose(after, AMBIENT + drift[times > 17.0] - 2.0 * tau, atol=0.5)


def test_pressure_detector_refuses_bad_settings_and_time_going_backwards():
    with pytest.raises(ValueError, match="end_threshold_pa"):
        PressureDetectorConfig(start_threshold_pa=100.0, end_threshold_pa=120.0)
    detector = PressureContactDetector()
    detector.update(reading(1.0))
    with pytest.raises(ValueError, match="earlier"):
        detector.update(reading(0.5))
    with pytest.raises(ValueError, match="pressure"):
        detector.update(reading(2.0, float("nan")))


# --- IMU detectors -----------------------------------------------------------------------------

def test_acceleration_spikes_toggle_contact_and_noise_does_not():
    rng = np.random.default_rng(2)
    times = np.arange(0.0, 60.0, 0.01)
    lin_acc = 0.0116 * rng.standard_normal((len(times), 3))  # BNO055 per-sample noise
    lin_acc[100] += [0.0, 0.0, 1.5]  # touch
    lin_acc[103] += [0.0, 0.0, -1.0]  # a rebound inside the refractory time
    lin_acc[3000] += [0.8, 0.0, 0.0]  # release
    detector = AccelerationSpikeDetector()
    events = detector.process(reading(t, lin_acc=a) for t, a in zip(times, lin_acc))
    assert [(e.kind, e.t_s) for e in events] == [("start", times[100]), ("end", times[3000])]
    assert events[0].signal == pytest.approx(1.5, abs=0.1)


def test_orientation_change_starts_a_contact_when_the_pad_turns():
    times = np.arange(0.0, 2.0, 0.01)
    turn_start, rate = 1.0, math.radians(100.0)  # the pad aligns: 5 degrees in 50 ms
    angle = np.clip(times - turn_start, 0.0, 0.05) * rate
    rng = np.random.default_rng(3)
    jitter = np.radians(0.07) * rng.standard_normal((len(times), 3))
    quats = [np.array([math.cos(a / 2), math.sin(a / 2), 0.0, 0.0]) + np.r_[0.0, j / 2] for a, j in zip(angle, jitter)]
    detector = OrientationChangeDetector()
    events = detector.process(reading(t, quat=q / np.linalg.norm(q)) for t, q in zip(times, quats))
    assert len(events) == 1 and events[0].kind == "start"
    # The 0.1 s look-back sees 2 degrees after 20 ms of turning.
    assert turn_start + 0.01 <= events[0].t_s <= turn_start + 0.04
    assert detector.in_contact


def test_detectors_forget_everything_on_reset():
    detector = PressureContactDetector()
    detector.process(pressure_stream([0.0, 0.1, 0.2], [AMBIENT, AMBIENT + 500.0, AMBIENT + 500.0]))
    assert detector.in_contact
    detector.reset()
    assert not detector.in_contact and detector.baseline_pa is None


# --- slow presses, creep and the bubble's temperature (hardware-like pads) ----------------------

@pytest.mark.parametrize("rate_pa_s", [10.0, 30.0, 100.0, 1000.0])
def test_a_slowly_loading_press_is_confirmed_before_its_rise_reaches_twice_the_threshold(rate_pa_s):
    """A soft pad meeting a tilted surface loads up at tens of Pa/s; the baseline must not absorb it.
    (At 10 Pa/s the slow held tracking still takes ~45 Pa of the rise over the 15 s it lasts.)"""
    config = PressureDetectorConfig()
    rng = np.random.default_rng(int(rate_pa_s))
    times = np.arange(0.0, 5.0 + 300.0 / rate_pa_s, PERIOD)
    rise = np.clip(rate_pa_s * (times - 5.0), 0.0, None)
    events = PressureContactDetector(config).process(
        pressure_stream(times, AMBIENT + rise + 2.1 * rng.standard_normal(len(times))))
    assert [e.kind for e in events] == ["start"]
    true_rise_at_start = rate_pa_s * (events[0].t_s - 5.0)
    assert config.start_threshold_pa < true_rise_at_start
    assert true_rise_at_start < 2 * config.start_threshold_pa + rate_pa_s * (2 * PERIOD + config.min_start_duration_s)


def test_without_the_hold_band_a_slow_press_is_absorbed_into_the_baseline():
    """The failure the hold band removes: a 2 s average follows a 10 Pa/s rise 20 Pa behind, forever."""
    times = np.arange(0.0, 30.0, PERIOD)
    pressures = AMBIENT + np.clip(10.0 * (times - 5.0), 0.0, None)
    old = PressureDetectorConfig(baseline_hold_pa=None)
    assert PressureContactDetector(old).process(pressure_stream(times, pressures)) == []
    assert [e.kind for e in PressureContactDetector().process(pressure_stream(times, pressures))] == ["start"]


@pytest.mark.parametrize("temperature_difference_k", [-5.0, 5.0])
def test_creep_and_contact_temperature_give_one_contact_per_press_and_nothing_after(temperature_difference_k):
    """Three 10 s presses of a pad that creeps 10 % and whose sealed bubble takes the object's
    temperature (110 Pa/K, 140 s), each followed by 60 s free: three starts, three ends."""
    from sensor.sim.pad_drift import PadDrift, PadDriftState
    from sensor.sim.pad_response import PadResponse

    pad = PadResponse()
    drift = PadDriftState(PadDrift(creep_fraction=0.1, thermal_pa_per_k=110.0,
                                   contact_temperature_difference_k=temperature_difference_k))
    rng = np.random.default_rng(3)
    times = np.arange(0.0, 3 * 71.0, PERIOD)
    phase = np.mod(times - 1.0, 71.0)
    force = np.where(times < 1.0, 0.0, np.clip(np.minimum(phase, 11.0 - phase), 0.0, 1.0) * 1.5)  # 1 s ramps
    pressures = []
    for f in force:
        rise = pad.pressure_rise_pa(f)
        pressures.append(AMBIENT + rise + drift.step(rise, f > 0.0, PERIOD) + 2.1 * rng.standard_normal())
    assert abs(drift.temperature_change_k) > 0.1  # the bubble's temperature moved
    events = PressureContactDetector().process(pressure_stream(times, pressures))
    assert [e.kind for e in events] == ["start", "end"] * 3
    starts = [e.t_s for e in events if e.kind == "start"]
    assert all(0.0 < s - (1.0 + 71.0 * k) < 0.5 for k, s in enumerate(starts))


def test_hold_band_settings_are_checked():
    with pytest.raises(ValueError, match="baseline_hold_pa"):
        PressureDetectorConfig(baseline_hold_pa=150.0)
    with pytest.raises(ValueError, match="held_baseline_time_constant_s"):
        PressureDetectorConfig(held_baseline_time_constant_s=1.0)
