"""Simulated sensor chips (BNO055 IMU, BMP280 barometer under the pad); pure numpy, no simulator."""
from sensor.sim.bmp280 import BMP280Config, BMP280Noise, PressureSample, SimulatedBMP280
from sensor.sim.bno055 import BNO055Config, BNO055Noise, ImuSample, SimulatedBNO055
from sensor.sim.pad_drift import PadDrift
from sensor.sim.pad_response import PadResponse

__all__ = [
    "BMP280Config", "BMP280Noise", "PressureSample", "SimulatedBMP280",
    "BNO055Config", "BNO055Noise", "ImuSample", "SimulatedBNO055",
    "PadDrift", "PadResponse",
]
