"""The plain, timestamped record every tactile sensor backend produces."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Reading:
    """One snapshot of the fingertip sensor.

    Channels sampled at different rates hold their newest value (sample-and-hold), as a
    microcontroller that reads both chips would report them.

    Attributes
    ----------
    t_s : float
        Time stamp, seconds (simulation clock or the host's monotonic clock).
    pressure_pa : float
        Absolute pressure of the barometer under the pad, pascals.
    quat_wxyz : (4,) float
        Orientation of the sensor body in the world frame, unit quaternion (w, x, y, z).
    lin_acc_mps2 : (3,) float
        Linear acceleration without gravity, sensor frame, m/s^2.
    gravity_mps2 : (3,) float
        Gravity vector, sensor frame, m/s^2.
    temperature_c : float
        Barometer temperature, degrees Celsius.
    """

    t_s: float
    pressure_pa: float
    quat_wxyz: np.ndarray
    lin_acc_mps2: np.ndarray
    gravity_mps2: np.ndarray
    temperature_c: float = 25.0
