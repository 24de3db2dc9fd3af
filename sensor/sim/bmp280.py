"""Simulated Bosch BMP280 barometer cast under the polyurethane pad.

Figures from the BMP280 data sheet (Bosch Sensortec, BST-BMP280-DS001, rev. 1.14 and later):

- Table 4 (section 3.3.1): pressure resolution per oversampling setting, 2.62 / 1.31 / 0.66 / 0.33 /
  0.16 Pa for x1 / x2 / x4 / x8 / x16; section 3.3.3: with the IIR filter on, output is 20 bit
  (0.16 Pa).
- Table 8 (section 3.5): typical RMS pressure noise per oversampling and IIR filter setting, in
  ``RMS_NOISE_PA`` below. Cross-checked against Table 7 (section 3.4), whose RMS noise column is the
  same figures in centimetres of altitude (8 cm per Pa near sea level).
- Table 6 (section 3.3.3): IIR filter, samples to reach >= 75 % of a step: 2 / 5 / 11 / 22 for
  coefficients 2 / 4 / 8 / 16; filtered = (old * (c - 1) + new) / c.
- Table 13 (section 3.8.1): typical measurement time 5.5 / 7.5 / 11.5 / 19.5 / 37.5 ms; normal mode
  output data rate = 1 / (t_measure + t_standby) (section 3.8.2, Table 14: 166.7 / 125 / 83.3 / 50 /
  26.3 Hz with t_standby = 0.5 ms). Table 11 (section 3.6.3): standby times.
- Key parameters (page 2): temperature coefficient of offset 1.5 Pa/K.

Slow drift (ambient pressure, temperature) is not a chip figure: it is modelled as a random walk plus
an optional linear trend, with defaults of a few pascals per minute as seen indoors.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from common.pad_state import PadState
from sensor.sim.pad_drift import PadDrift, PadDriftState
from sensor.sim.pad_response import PadResponse
from sensor.sim.sampling import SampleClock

#: Table 4: typical pressure resolution, pascals, by pressure oversampling factor (IIR off).
RESOLUTION_PA = {1: 2.62, 2: 1.31, 4: 0.66, 8: 0.33, 16: 0.16}
#: Section 3.3.3: resolution with the IIR filter on (20 bit), pascals.
RESOLUTION_IIR_PA = 0.16
#: Table 8: typical RMS pressure noise, pascals, [oversampling][IIR coefficient] (0 = filter off).
RMS_NOISE_PA = {
    1: {0: 3.3, 2: 1.9, 4: 1.2, 8: 0.9, 16: 0.4},
    2: {0: 2.6, 2: 1.5, 4: 1.0, 8: 0.6, 16: 0.4},
    4: {0: 2.1, 2: 1.2, 4: 0.8, 8: 0.5, 16: 0.3},
    8: {0: 1.6, 2: 1.0, 4: 0.6, 8: 0.4, 16: 0.2},
    16: {0: 1.3, 2: 0.8, 4: 0.5, 8: 0.4, 16: 0.2},
}
#: Table 13: typical measurement time, seconds, by pressure oversampling (recommended osrs_t).
MEASUREMENT_TIME_S = {1: 5.5e-3, 2: 7.5e-3, 4: 11.5e-3, 8: 19.5e-3, 16: 37.5e-3}
#: Table 11: normal-mode standby times t_sb, seconds.
STANDBY_TIMES_S = (0.0005, 0.0625, 0.125, 0.25, 0.5, 1.0, 2.0, 4.0)
#: Key parameters: temperature coefficient of offset, pascals per kelvin.
TEMPERATURE_OFFSET_PA_PER_K = 1.5


@dataclass(frozen=True)
class BMP280Noise:
    """Random and slow error sources of the barometer.

    Attributes
    ----------
    white_noise_scale : float
        Multiplier on the data-sheet RMS noise of the chosen setting (Table 8); 0 switches it off.
    pressure_random_walk_pa_per_sqrt_s : float
        Random walk of the ambient pressure, Pa/sqrt(s); 0.4 gives about 3 Pa RMS per minute.
    pressure_trend_pa_per_s : float
        Linear ambient pressure trend, Pa/s (weather: ~0.03 Pa/s is 1 hPa per hour); default 0.
    temperature_random_walk_k_per_sqrt_s : float
        Random walk of the chip temperature, K/sqrt(s); it shifts the pressure by the data sheet's
        1.5 Pa/K offset coefficient and is reported as the reading's temperature.
    """

    white_noise_scale: float = 1.0
    pressure_random_walk_pa_per_sqrt_s: float = 0.4
    pressure_trend_pa_per_s: float = 0.0
    temperature_random_walk_k_per_sqrt_s: float = 0.005

    def __post_init__(self) -> None:
        for name in ("white_noise_scale", "pressure_random_walk_pa_per_sqrt_s",
                     "temperature_random_walk_k_per_sqrt_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} must be finite and >= 0, got {value}")
        if not math.isfinite(self.pressure_trend_pa_per_s):
            raise ValueError(f"pressure_trend_pa_per_s must be finite, got {self.pressure_trend_pa_per_s}")

    @classmethod
    def off(cls) -> "BMP280Noise":
        """No white noise, no drift."""
        return cls(0.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class BMP280Config:
    """Settings of the simulated barometer and its pad.

    Attributes
    ----------
    oversampling : int
        Pressure oversampling factor osrs_p: 1, 2, 4 (default, "standard resolution"), 8 or 16.
    iir_coefficient : int
        IIR filter coefficient: 0 (off, default: fastest contact response), 2, 4, 8 or 16.
    standby_s : float
        Normal-mode standby time t_sb, seconds, one of Table 11's values (default 0.5 ms).
    ambient_pressure_pa : float
        Free-pad absolute pressure at start, pascals.
    ambient_temperature_c : float
        Chip temperature at start, degrees Celsius.
    pad : PadResponse
        Force-to-pressure response of the pad.
    noise : BMP280Noise
        Noise and drift; ``BMP280Noise.off()`` for noise-free runs.
    quantise : bool
        Round outputs to the setting's resolution (Table 4).
    pad_drift : PadDrift
        Creep and contact-temperature effects of the pad (default off).
    """

    oversampling: int = 4
    iir_coefficient: int = 0
    standby_s: float = 0.0005
    ambient_pressure_pa: float = 101325.0
    ambient_temperature_c: float = 25.0
    pad: PadResponse = field(default_factory=PadResponse)
    noise: BMP280Noise = field(default_factory=BMP280Noise)
    quantise: bool = True
    pad_drift: PadDrift = field(default_factory=PadDrift)

    def __post_init__(self) -> None:
        if self.oversampling not in RMS_NOISE_PA:
            raise ValueError(f"oversampling must be one of {sorted(RMS_NOISE_PA)}, got {self.oversampling}")
        if self.iir_coefficient not in RMS_NOISE_PA[1]:
            raise ValueError(
                f"iir_coefficient must be one of {sorted(RMS_NOISE_PA[1])} (0 = off), got {self.iir_coefficient}"
            )
        if not any(math.isclose(self.standby_s, t) for t in STANDBY_TIMES_S):
            raise ValueError(f"standby_s must be one of {STANDBY_TIMES_S} s, got {self.standby_s}")
        if not (300e2 <= self.ambient_pressure_pa <= 1100e2):
            raise ValueError(
                f"ambient_pressure_pa {self.ambient_pressure_pa} Pa is outside the BMP280's 300..1100 hPa range"
            )

    @property
    def rms_noise_pa(self) -> float:
        """Output RMS noise of this setting (Table 8), pascals, before ``white_noise_scale``."""
        return RMS_NOISE_PA[self.oversampling][self.iir_coefficient]

    @property
    def resolution_pa(self) -> float:
        """Output quantisation step, pascals (Table 4; 0.16 Pa with the IIR filter on)."""
        return RESOLUTION_IIR_PA if self.iir_coefficient else RESOLUTION_PA[self.oversampling]

    @property
    def sample_period_s(self) -> float:
        """Normal-mode time between samples: typical measurement time plus standby, seconds."""
        return MEASUREMENT_TIME_S[self.oversampling] + self.standby_s

    def noiseless(self) -> "BMP280Config":
        """The same settings with noise and drift switched off (quantisation kept)."""
        return replace(self, noise=BMP280Noise.off(), pad_drift=PadDrift())


@dataclass(frozen=True)
class PressureSample:
    """One barometer output.

    Attributes
    ----------
    t_s : float
        Simulation time of the sample, seconds.
    pressure_pa : float
        Absolute pressure, pascals.
    temperature_c : float
        Chip temperature, degrees Celsius.
    """

    t_s: float
    pressure_pa: float
    temperature_c: float


class SimulatedBMP280:
    """Barometer under the pad, sampled in normal mode at the setting's own rate.

    Call :meth:`step` after every physics step; it returns a :class:`PressureSample` on the steps
    where the chip completes a measurement (the first step at or after each due time), else None.

    Parameters
    ----------
    config : BMP280Config
        Chip and pad settings.
    rng : numpy.random.Generator
        Source of all randomness of this chip.
    """

    def __init__(self, config: BMP280Config, rng: np.random.Generator) -> None:
        self.config = config
        self._rng = rng
        self._clock = SampleClock(config.sample_period_s)
        coefficient = config.iir_coefficient
        # Raw noise that, after the IIR filter, has the data sheet's output RMS (variance / (2c - 1)).
        self._raw_noise_pa = (config.rms_noise_pa * config.noise.white_noise_scale
                              * math.sqrt(2 * coefficient - 1 if coefficient else 1))
        self._ambient_pa = config.ambient_pressure_pa
        self._temperature_c = config.ambient_temperature_c
        self._rise_pa: float | None = None
        self._pad_drift = PadDriftState(config.pad_drift)
        self._drifts = not config.pad_drift.is_off
        self._drift_pa = 0.0
        self._filtered_pa: float | None = None
        self._last_step_t: float | None = None
        self._last_sample_t: float | None = None

    def step(self, pad_state: PadState) -> PressureSample | None:
        """Advance to ``pad_state.t_s`` with the pad's normal force; return a sample if one is due."""
        return self.step_force(pad_state.t_s, pad_state.normal_force_n)

    def step_force(self, t: float, normal_force_n: float) -> PressureSample | None:
        """:meth:`step` from the two values it reads: time (s) and the pad's normal force (N)."""
        pad = self.config.pad
        if self._rise_pa is None:
            self._rise_pa = pad.pressure_rise_pa(normal_force_n)
        else:
            dt = t - self._last_step_t
            self._rise_pa = pad.lag_step(self._rise_pa, normal_force_n, dt)
            if self._drifts:
                self._drift_pa = self._pad_drift.step(self._rise_pa, normal_force_n > 0.0, dt)
        self._last_step_t = t
        if not self._clock.due(t):
            return None
        return self._measure(t)

    def _measure(self, t: float) -> PressureSample:
        noise = self.config.noise
        if self._last_sample_t is not None:
            dt = t - self._last_sample_t
            self._ambient_pa += (noise.pressure_trend_pa_per_s * dt
                                 + noise.pressure_random_walk_pa_per_sqrt_s * math.sqrt(dt) * self._rng.standard_normal())
            self._temperature_c += noise.temperature_random_walk_k_per_sqrt_s * math.sqrt(dt) * self._rng.standard_normal()
        self._last_sample_t = t
        temperature_offset = TEMPERATURE_OFFSET_PA_PER_K * (self._temperature_c - self.config.ambient_temperature_c)
        raw = self._ambient_pa + temperature_offset + self._rise_pa + self._drift_pa
        if self._raw_noise_pa:
            raw += self._raw_noise_pa * self._rng.standard_normal()
        coefficient = self.config.iir_coefficient
        if coefficient and self._filtered_pa is not None:
            self._filtered_pa += (raw - self._filtered_pa) / coefficient
        else:
            self._filtered_pa = raw
        pressure = self._filtered_pa
        temperature = self._temperature_c
        if self.config.quantise:
            step = self.config.resolution_pa
            pressure = round(pressure / step) * step
            temperature = round(temperature * 100.0) / 100.0  # compensated output is 0.01 degC
        return PressureSample(t_s=t, pressure_pa=pressure, temperature_c=temperature)
