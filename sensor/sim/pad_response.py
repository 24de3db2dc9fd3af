"""Pressure rise under the polyurethane pad as a function of the normal force on it.

The barometer sits in a small air bubble under an elastic pad; pressing the pad compresses the bubble.
The rise is monotonic and saturating (the bubble cannot be compressed without bound, and the pad
carries more of the load as it stiffens), and it lags the force by a short first-order time constant
(viscoelastic polyurethane, air flow into the chip's port)::

    dP_steady(F) = P_sat * (1 - exp(-F / F0))
    tau * d(dP)/dt = dP_steady(F) - dP

The same object inverts the steady-state curve to estimate force from a measured pressure rise.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PadResponse:
    """Steady-state and dynamic pressure response of the pad.

    Defaults give an initial slope of P_sat / F0 = 600 Pa/N, so 0.3 N already raises the pressure by
    about 170 Pa and 0.5 N by about 285 Pa, well above a ~100 Pa contact threshold.

    Attributes
    ----------
    saturation_pa : float
        P_sat, pressure rise the pad approaches under large force, pascals (default 3000 Pa).
    force_scale_n : float
        F0, force at which the rise reaches 1 - 1/e (63 %) of P_sat, newtons (default 5 N).
    lag_time_constant_s : float
        tau, first-order lag of the pressure rise behind the force, seconds (default 0.02 s).
    """

    saturation_pa: float = 3000.0
    force_scale_n: float = 5.0
    lag_time_constant_s: float = 0.02

    def __post_init__(self) -> None:
        if not self.saturation_pa > 0.0:
            raise ValueError(f"saturation_pa must be > 0 Pa, got {self.saturation_pa}")
        if not self.force_scale_n > 0.0:
            raise ValueError(f"force_scale_n must be > 0 N, got {self.force_scale_n}")
        if not self.lag_time_constant_s >= 0.0:
            raise ValueError(f"lag_time_constant_s must be >= 0 s, got {self.lag_time_constant_s}")

    def pressure_rise_pa(self, force_n):
        """Steady-state pressure rise for a normal force.

        Parameters
        ----------
        force_n : float or (n,) float
            Normal force on the pad, newtons, >= 0.

        Returns
        -------
        float or (n,) float
            Pressure rise, pascals, in [0, saturation_pa).
        """
        if type(force_n) is float or np.ndim(force_n) == 0:  # scalar path: called every physics step
            force = float(force_n)
            if not (math.isfinite(force) and force >= 0.0):
                raise ValueError(f"force_n must be finite and >= 0 N, got {force_n!r}")
            return self.saturation_pa * -math.expm1(-force / self.force_scale_n)
        force = np.asarray(force_n, dtype=float)
        if np.any(~np.isfinite(force)) or np.any(force < 0.0):
            raise ValueError(f"force_n must be finite and >= 0 N, got {force_n!r}")
        return self.saturation_pa * -np.expm1(-force / self.force_scale_n)

    def force_estimate_n(self, pressure_rise_pa: float) -> float:
        """Force for a measured rise, clipped into the invertible range (a negative rise is 0 N;
        a saturated one reads as the force at 99.9 % of saturation)."""
        return float(self.force_n(min(max(float(pressure_rise_pa), 0.0), 0.999 * self.saturation_pa)))

    def force_n(self, pressure_rise_pa):
        """Invert the steady-state curve: the force that produces a pressure rise.

        A negative rise (noise or drift below the baseline) maps to a negative force of the same
        small size, so that averages of noisy estimates stay unbiased near zero; clip if needed.

        Parameters
        ----------
        pressure_rise_pa : float or (n,) float
            Pressure above the free-pad baseline, pascals, < saturation_pa.

        Returns
        -------
        float or (n,) float
            Normal force, newtons.

        Raises
        ------
        ValueError
            If a rise is at or above saturation_pa, where the force is not observable.
        """
        rise = np.asarray(pressure_rise_pa, dtype=float)
        if np.any(~np.isfinite(rise)):
            raise ValueError(f"pressure_rise_pa must be finite, got {pressure_rise_pa!r}")
        if np.any(rise >= self.saturation_pa):
            raise ValueError(
                f"pressure rise {np.max(rise):.1f} Pa is at or above the pad's saturation "
                f"{self.saturation_pa:.1f} Pa: the force cannot be recovered"
            )
        force = -self.force_scale_n * np.log1p(-rise / self.saturation_pa)
        return float(force) if force.ndim == 0 else force

    def lag_step(self, rise_pa: float, force_n: float, dt_s: float) -> float:
        """Advance the lagged pressure rise by ``dt_s`` with the force held constant.

        Exact discretisation of the first-order lag under a zero-order hold on the force.

        Parameters
        ----------
        rise_pa : float
            Current lagged pressure rise, pascals.
        force_n : float
            Normal force over the interval, newtons.
        dt_s : float
            Interval, seconds, >= 0.

        Returns
        -------
        float
            Lagged pressure rise at the end of the interval, pascals.
        """
        target = self.pressure_rise_pa(force_n)
        if self.lag_time_constant_s == 0.0:
            return target
        keep = math.exp(-dt_s / self.lag_time_constant_s)
        return target + (rise_pa - target) * keep
