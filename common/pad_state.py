"""Ground-truth state of the sensor pad, as the simulator knows it.

The simulated sensor models turn a stream of these into :class:`sensor.reading.Reading` records;
the PyBullet glue produces them. Plain numpy data, no simulator ids.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PadState:
    """True state of the sensor body at one simulation step.

    Attributes
    ----------
    t_s : float
        Simulation time, seconds.
    position_m : (3,) float
        Sensor body origin, world frame, metres.
    quat_wxyz : (4,) float
        Sensor body orientation, world frame, unit quaternion (w, x, y, z).
    lin_vel_mps : (3,) float
        Sensor body linear velocity, world frame, m/s.
    ang_vel_radps : (3,) float
        Sensor body angular velocity, world frame, rad/s.
    normal_force_n : float
        The pad's contact load as its barometer feels it, newtons (0 when free): each contact
        force's component along the face axis plus a small fraction of its component across it
        (``RobotSpec.pad_side_pressure_gain``).
    contact_point_m : (3,) float or None
        Force-weighted mean contact point on the object, world frame, metres; None when free.
    contact_normal : (3,) float or None
        Force-weighted mean outward surface normal of the touched object, world frame; None when free.
    """

    t_s: float
    position_m: np.ndarray
    quat_wxyz: np.ndarray
    lin_vel_mps: np.ndarray
    ang_vel_radps: np.ndarray
    normal_force_n: float
    contact_point_m: np.ndarray | None = None
    contact_normal: np.ndarray | None = None
