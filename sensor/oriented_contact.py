"""The record of one detected contact: where, which way the surface faces, when and how hard."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sensor.reading import Reading


@dataclass(frozen=True)
class OrientedContact:
    """A contact with its surface normal.

    Attributes
    ----------
    t_s : float
        Time the contact was confirmed, seconds.
    position_m : (3,) float
        Contact point (centre of the pad face), world frame, metres.
    normal : (3,) float
        Outward unit surface normal, world frame.
    force_n : float
        Estimated normal force, newtons (from the pressure rise).
    readings : tuple of Reading
        The raw readings the contact was derived from.
    """

    t_s: float
    position_m: np.ndarray
    normal: np.ndarray
    force_n: float
    readings: tuple[Reading, ...] = field(default=(), repr=False)
