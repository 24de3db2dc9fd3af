"""When a chip running at its own output rate produces a sample on the simulation clock."""
from __future__ import annotations

import math

_TIME_TOLERANCE_S = 1e-9


class SampleClock:
    """A fixed-rate sample schedule observed only at physics-step times.

    The first observed time is the first sample. Afterwards a sample is produced on the first step
    at or after each due time; due times stay on the nominal grid ``t0 + k * period`` so the average
    rate is exact whatever the physics step. When a step spans several periods, only the newest
    sample survives (the chip overwrote its data register before anyone read it).

    Parameters
    ----------
    period_s : float
        Time between samples, seconds, > 0.
    """

    def __init__(self, period_s: float) -> None:
        if not period_s > 0.0:
            raise ValueError(f"sample period must be > 0 s, got {period_s}")
        self.period_s = period_s
        self._next_due_s: float | None = None

    def would_be_due(self, t_s: float) -> bool:
        """What :meth:`due` would answer at ``t_s``, without advancing the schedule."""
        return self._next_due_s is None or t_s >= self._next_due_s - _TIME_TOLERANCE_S

    def due(self, t_s: float) -> bool:
        """True when a sample falls due at time ``t_s``; advances the schedule if so."""
        if self._next_due_s is None:
            self._next_due_s = t_s + self.period_s
            return True
        if t_s < self._next_due_s - _TIME_TOLERANCE_S:
            return False
        periods_passed = math.floor((t_s - self._next_due_s + _TIME_TOLERANCE_S) / self.period_s) + 1
        self._next_due_s += periods_passed * self.period_s
        return True
