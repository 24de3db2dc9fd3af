"""Sensor variants fed the same physics, to tell the error sources apart."""
from __future__ import annotations

from dataclasses import replace

from sensor.sim.bno055 import BNO055Noise
from sensor.sim_sensor import SimulatedSensorConfig

DEFAULT = "default"
NOISELESS = "noiseless"
MOUNTING_ONLY = "mounting only"
NOISE_WITHOUT_MOUNTING = "chip noise only"


def sensor_variants(config: SimulatedSensorConfig | None = None) -> dict[str, SimulatedSensorConfig]:
    """The variants of ``config`` (default: ``SimulatedSensorConfig()``), live one first.

    * ``default``: ``config`` as given, every error source on;
    * ``noiseless``: no noise, bias, drift or misalignment: the physics' own error (spring, friction,
      contact geometry) plus quantisation;
    * ``mounting only``: just the chip's mounting misalignment;
    * ``chip noise only``: every source but the mounting misalignment (white noise, heading walk,
      tilt bias, barometer noise and drift).
    """
    config = config if config is not None else SimulatedSensorConfig()
    imu_noise = config.imu.noise
    mounting = replace(BNO055Noise.off(), mounting_misalignment_std_rad=imu_noise.mounting_misalignment_std_rad)
    noiseless = config.noiseless()
    return {
        DEFAULT: config,
        NOISELESS: noiseless,
        MOUNTING_ONLY: replace(noiseless, imu=replace(noiseless.imu, noise=mounting)),
        NOISE_WITHOUT_MOUNTING: replace(config, imu=replace(config.imu, noise=replace(
            imu_noise, mounting_misalignment_std_rad=0.0))),
    }
