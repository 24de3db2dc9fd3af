"""Simulated BMP280 under the pad, checked against the data sheet's tables and closed forms."""
import math
from dataclasses import replace

import numpy as np
import pytest

from common.pad_state import PadState
from sensor.sim.bmp280 import BMP280Config, BMP280Noise, SimulatedBMP280
from sensor.sim.pad_response import PadResponse


def pad_state(t_s, force_n=0.0):
    return PadState(t_s, np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(3), np.zeros(3), force_n)


def run(config, times, force=lambda t: 0.0, seed=0):
    """Samples of a chip stepped at ``times``; force(t) is the pad force at each step."""
    chip = SimulatedBMP280(config, np.random.default_rng(seed))
    samples = (chip.step(pad_state(t, force(t))) for t in times)
    return [s for s in samples if s is not None]


def ideal(config):
    """No noise, no drift, no quantisation."""
    return replace(config.noiseless(), quantise=False)


# --- pad response -----------------------------------------------------------------------------

def test_pad_curve_closed_form_and_contact_sensitivity():
    pad = PadResponse(saturation_pa=3000.0, force_scale_n=5.0)
    assert pad.pressure_rise_pa(0.0) == 0.0
    assert pad.pressure_rise_pa(5.0) == pytest.approx(3000.0 * (1.0 - math.exp(-1.0)), rel=1e-12)
    # Brief: ~0.3-0.5 N must already exceed a 100 Pa contact threshold with the defaults.
    assert PadResponse().pressure_rise_pa(0.3) > 100.0
    forces = np.linspace(0.0, 60.0, 200)
    rises = pad.pressure_rise_pa(forces)
    assert np.all(np.diff(rises) > 0.0) and np.all(rises < 3000.0)  # monotonic, saturating
    slope = (pad.pressure_rise_pa(1e-6) - 0.0) / 1e-6
    assert slope == pytest.approx(3000.0 / 5.0, rel=1e-5)  # initial slope P_sat / F0


def test_pad_inverse_round_trips_and_refuses_saturation():
    pad = PadResponse()
    forces = np.array([0.0, 0.01, 0.3, 2.0, 15.0])
    np.testing.assert_allclose(pad.force_n(pad.pressure_rise_pa(forces)), forces, rtol=1e-12, atol=1e-12)
    with pytest.raises(ValueError, match="saturation"):
        pad.force_n(pad.saturation_pa)
    with pytest.raises(ValueError, match="force_n"):
        pad.pressure_rise_pa(-0.1)


def test_pad_lag_is_exact_first_order_response():
    config = ideal(BMP280Config(pad=PadResponse(lag_time_constant_s=0.02)))
    dt, t_force = 0.0005, 0.1004  # the force appears at the step after t = 0.1, so the lag starts at 0.1
    times = np.arange(0.0, 0.3, dt)
    samples = run(config, times, force=lambda t: 1.0 if t >= t_force else 0.0)
    steady = config.pad.pressure_rise_pa(1.0)
    for s in samples:
        if s.t_s > t_force:
            expected = config.ambient_pressure_pa + steady * (1.0 - math.exp(-(s.t_s - 0.1) / 0.02))
            assert s.pressure_pa == pytest.approx(expected, abs=1e-6)


# --- timing, noise, filter: data sheet tables --------------------------------------------------

@pytest.mark.parametrize("oversampling, table_14_rate_hz", [(1, 166.67), (2, 125.0), (4, 83.33), (8, 50.0), (16, 26.32)])
def test_output_rate_matches_table_14(oversampling, table_14_rate_hz):
    config = BMP280Config(oversampling=oversampling)
    assert 1.0 / config.sample_period_s == pytest.approx(table_14_rate_hz, abs=0.01)
    duration = 3.0
    samples = run(config, np.arange(0.0, duration, 1.0 / 240.0))  # physics at 240 Hz
    assert abs(len(samples) - duration * table_14_rate_hz) <= 1.5


@pytest.mark.parametrize("oversampling, iir, n", [(1, 0, 6000), (4, 0, 6000), (16, 0, 6000), (4, 16, 40000)])
def test_white_noise_matches_table_8(oversampling, iir, n):
    config = BMP280Config(oversampling=oversampling, iir_coefficient=iir,
                          noise=BMP280Noise(1.0, 0.0, 0.0, 0.0))
    samples = run(config, np.arange(n) * config.sample_period_s)
    pressures = np.array([s.pressure_pa for s in samples[200:]])  # skip the IIR start-up
    table = {(1, 0): 3.3, (4, 0): 2.1, (16, 0): 1.3, (4, 16): 0.3}[(oversampling, iir)]
    expected = math.hypot(table, config.resolution_pa / math.sqrt(12.0))  # plus quantisation noise
    assert np.std(pressures) == pytest.approx(expected, rel=0.06)


@pytest.mark.parametrize("coefficient, table_6_samples", [(2, 2), (4, 5), (8, 11), (16, 22)])
def test_iir_step_response_matches_table_6(coefficient, table_6_samples):
    config = ideal(BMP280Config(iir_coefficient=coefficient, pad=PadResponse(lag_time_constant_s=0.0)))
    period = config.sample_period_s
    times = np.arange(200) * period
    step_index = 50
    samples = run(config, times, force=lambda t: 2.0 if t >= times[step_index] - 1e-9 else 0.0)
    rise = np.array([s.pressure_pa for s in samples]) - config.ambient_pressure_pa
    fraction = rise[step_index:] / config.pad.pressure_rise_pa(2.0)
    samples_to_75 = int(np.argmax(fraction >= 0.75)) + 1
    assert samples_to_75 == table_6_samples


def test_resolution_follows_table_4_and_outputs_are_quantised():
    assert BMP280Config(oversampling=1).resolution_pa == 2.62
    assert BMP280Config(oversampling=16).resolution_pa == 0.16
    for config in (BMP280Config(), BMP280Config(iir_coefficient=4)):
        pressures = np.array([s.pressure_pa for s in run(config, np.arange(300) * config.sample_period_s)])
        steps = pressures / config.resolution_pa
        np.testing.assert_allclose(steps, np.round(steps), atol=1e-6)
        assert len(np.unique(pressures)) > 3  # noise moves it across several steps


# --- drift -------------------------------------------------------------------------------------

def test_ambient_random_walk_has_the_configured_rate():
    config = replace(BMP280Config(noise=BMP280Noise(0.0, 0.4, 0.0, 0.0)), quantise=False)
    pressures = np.array([s.pressure_pa for s in run(config, np.arange(0.0, 4000.0, 1.0))])
    increments = np.diff(pressures)
    assert np.std(increments) == pytest.approx(0.4, rel=0.05)  # 0.4 Pa/sqrt(s) over 1 s steps
    assert abs(np.mean(increments)) < 0.05


def test_linear_trend_is_exact_without_noise():
    config = replace(BMP280Config(noise=BMP280Noise(0.0, 0.0, 0.03, 0.0)), quantise=False)
    samples = run(config, np.arange(0.0, 600.0, 0.5))
    rises = np.array([s.pressure_pa for s in samples]) - config.ambient_pressure_pa
    np.testing.assert_allclose(rises, 0.03 * np.array([s.t_s for s in samples]), atol=1e-7)


def test_temperature_drift_shifts_pressure_by_datasheet_coefficient():
    config = replace(BMP280Config(noise=BMP280Noise(0.0, 0.0, 0.0, 0.05)), quantise=False)
    samples = run(config, np.arange(0.0, 300.0, 1.0))
    dtemp = np.array([s.temperature_c for s in samples]) - config.ambient_temperature_c
    dp = np.array([s.pressure_pa for s in samples]) - config.ambient_pressure_pa
    assert np.ptp(dtemp) > 0.1
    np.testing.assert_allclose(dp, 1.5 * dtemp, atol=1e-7)  # 1.5 Pa/K, data sheet key parameters


# --- switches, seeds, validation ---------------------------------------------------------------

def test_noiseless_free_pad_reads_ambient_and_a_press_reads_the_pad_curve():
    config = BMP280Config().noiseless()
    samples = run(config, np.arange(0.0, 2.0, 1.0 / 240.0), force=lambda t: 1.5 if t >= 1.0 else 0.0)
    free = {s.pressure_pa for s in samples if s.t_s < 1.0}
    res = config.resolution_pa
    assert free == {round(config.ambient_pressure_pa / res) * res}
    pressed = samples[-1].pressure_pa - config.ambient_pressure_pa
    assert pressed == pytest.approx(config.pad.pressure_rise_pa(1.5), abs=res)


def test_same_seed_same_stream_other_seed_other_stream():
    times = np.arange(0.0, 1.0, 1.0 / 240.0)
    a = [s.pressure_pa for s in run(BMP280Config(), times, seed=3)]
    b = [s.pressure_pa for s in run(BMP280Config(), times, seed=3)]
    c = [s.pressure_pa for s in run(BMP280Config(), times, seed=4)]
    assert a == b and a != c


@pytest.mark.parametrize("kwargs, word", [
    ({"oversampling": 3}, "oversampling"),
    ({"iir_coefficient": 5}, "iir_coefficient"),
    ({"standby_s": 0.01}, "standby_s"),
    ({"ambient_pressure_pa": 20000.0}, "ambient_pressure_pa"),
])
def test_bad_settings_are_refused_by_name(kwargs, word):
    with pytest.raises(ValueError, match=word):
        BMP280Config(**kwargs)
    with pytest.raises(ValueError, match="pressure_random_walk"):
        BMP280Noise(pressure_random_walk_pa_per_sqrt_s=-1.0)


def test_force_estimate_clips_outside_the_invertible_range():
    from sensor.sim.pad_response import PadResponse

    pad = PadResponse()
    assert pad.force_estimate_n(-50.0) == 0.0
    assert pad.force_estimate_n(pad.pressure_rise_pa(1.2)) == pytest.approx(1.2)
    saturated = pad.force_estimate_n(10 * pad.saturation_pa)
    assert saturated == pytest.approx(pad.force_n(0.999 * pad.saturation_pa))
