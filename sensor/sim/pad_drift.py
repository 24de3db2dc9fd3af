"""Slow changes of the pressure under the pad that are not the force: creep and contact temperature.

* Creep: polyurethane is viscoelastic; under a held load the pad keeps compressing the air bubble
  for a while, so the pressure rise grows by a fraction of itself with a slow time constant
  (first-order, on top of :class:`sensor.sim.pad_response.PadResponse`'s fast lag).
* Temperature: the bubble is sealed by the cast pad, so its pressure follows its temperature
  (isochoric gas: ``dP/dT = P / T``, about 340 Pa/K at room conditions, less the share the pad's
  compliance absorbs). Touching an object of another temperature pulls the bubble's temperature
  towards it through the pad with the pad's thermal time constant (``thickness^2 / diffusivity``,
  about (3.7 mm)^2 / 1e-7 m^2/s = 140 s for polyurethane); released, it relaxes back.
"""
from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class PadDrift:
    """Creep and thermal parameters of the pad (all 0: off, the default).

    Attributes
    ----------
    creep_fraction : float
        Relative growth of a held pressure rise after a long hold (0.1: 10 %).
    creep_time_constant_s : float
        Time constant of that growth, seconds.
    thermal_pa_per_k : float
        Pressure change of the sealed bubble per kelvin of its temperature, Pa/K.
    contact_temperature_difference_k : float
        Touched object's temperature minus the pad's free temperature, kelvin.
    thermal_time_constant_s : float
        Time constant of the bubble's temperature through the pad, seconds.
    """

    creep_fraction: float = 0.0
    creep_time_constant_s: float = 1.0
    thermal_pa_per_k: float = 0.0
    contact_temperature_difference_k: float = 0.0
    thermal_time_constant_s: float = 140.0

    def __post_init__(self) -> None:
        for name, value in vars(self).items():
            if not math.isfinite(value):
                raise ValueError(f"PadDrift.{name} must be finite, got {value}")
        for name in ("creep_fraction", "thermal_pa_per_k"):
            if getattr(self, name) < 0.0:
                raise ValueError(f"PadDrift.{name} must be >= 0, got {getattr(self, name)}")
        for name in ("creep_time_constant_s", "thermal_time_constant_s"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"PadDrift.{name} must be > 0 s, got {getattr(self, name)}")

    @property
    def is_off(self) -> bool:
        return self.creep_fraction == 0.0 and (self.thermal_pa_per_k == 0.0
                                               or self.contact_temperature_difference_k == 0.0)


class PadDriftState:
    """The creep and bubble-temperature states of one pad; :meth:`step` after every physics step."""

    def __init__(self, drift: PadDrift) -> None:
        self.drift = drift
        self.creep_pa = 0.0
        self.temperature_change_k = 0.0

    def step(self, rise_pa: float, in_contact: bool, dt_s: float) -> float:
        """Advance by ``dt_s`` with the pad's current force-driven rise; return the extra pressure, Pa."""
        d = self.drift
        if dt_s > 0.0:
            keep = math.exp(-dt_s / d.creep_time_constant_s)
            self.creep_pa = d.creep_fraction * rise_pa + (self.creep_pa - d.creep_fraction * rise_pa) * keep
            target = d.contact_temperature_difference_k if in_contact else 0.0
            keep = math.exp(-dt_s / d.thermal_time_constant_s)
            self.temperature_change_k = target + (self.temperature_change_k - target) * keep
        return self.creep_pa + d.thermal_pa_per_k * self.temperature_change_k
