"""A manual clock so that drivers' waits cost no real time in tests."""
from __future__ import annotations


class FakeClock:
    """Monotonic time that only moves when someone sleeps or advances it.

    Pass ``clock.monotonic`` as a driver's ``clock`` and ``clock.sleep`` as its ``sleep``.

    Attributes
    ----------
    now : float
        Current time, seconds.
    slept_s : float
        Total time requested through :meth:`sleep`, seconds.
    """

    def __init__(self, start_s: float = 0.0):
        self.now = float(start_s)
        self.slept_s = 0.0

    def monotonic(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        if seconds < 0:
            raise ValueError(f"sleep length must be non-negative, got {seconds}")
        self.now += seconds
        self.slept_s += seconds

    def advance(self, seconds: float) -> None:
        """Let time pass without anyone sleeping (e.g. a port read blocking for its timeout)."""
        if seconds < 0:
            raise ValueError(f"time cannot go back ({seconds} s)")
        self.now += seconds
