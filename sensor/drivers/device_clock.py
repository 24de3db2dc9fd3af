"""Mapping a microcontroller's millisecond counter onto the host's monotonic clock."""
from __future__ import annotations

from collections import deque


class DeviceClockMapper:
    """Convert device time stamps (wrapping unsigned milliseconds) to host seconds.

    The host sees each sample some transport delay after the device stamped it; the delay is
    never negative, so ``host_arrival - device_time`` is smallest for the least-delayed
    samples. The offset is the minimum of that difference over a sliding window of host time,
    which follows a slow drift between the two crystals. Mapped times never go backwards.

    Parameters
    ----------
    window_s : float
        Length of the sliding window, seconds of host time.
    wrap_ms : int
        Counter modulus (2**32 for an Arduino ``millis()``).
    """

    def __init__(self, window_s: float = 10.0, wrap_ms: int = 1 << 32):
        if window_s <= 0:
            raise ValueError(f"window_s must be > 0, got {window_s}")
        self.window_s = window_s
        self.wrap_ms = wrap_ms
        self.device_resets = 0
        self._reset_state()

    def _reset_state(self) -> None:
        self._wraps = 0
        self._last_raw_ms: int | None = None
        self._window: deque[tuple[float, float]] = deque()  # (host arrival, offset), offsets increasing
        self._last_mapped = float("-inf")

    def map(self, device_ms: int, host_arrival_s: float) -> float:
        """Host-clock time (seconds) at which the device took the sample stamped ``device_ms``."""
        if not 0 <= device_ms < self.wrap_ms:
            raise ValueError(f"device time {device_ms} outside 0..{self.wrap_ms - 1} ms")
        if self._last_raw_ms is not None and device_ms < self._last_raw_ms:
            if self._last_raw_ms - device_ms > self.wrap_ms // 2:
                self._wraps += 1
            else:
                # a jump back that is not a wrap: the microcontroller restarted
                self.device_resets += 1
                last_mapped = self._last_mapped
                self._reset_state()
                self._last_mapped = last_mapped
        self._last_raw_ms = device_ms
        device_s = (self._wraps * self.wrap_ms + device_ms) * 1e-3
        offset = host_arrival_s - device_s
        while self._window and self._window[-1][1] >= offset:
            self._window.pop()
        self._window.append((host_arrival_s, offset))
        while self._window[0][0] < host_arrival_s - self.window_s:
            self._window.popleft()
        mapped = max(device_s + self._window[0][1], self._last_mapped)
        self._last_mapped = mapped
        return mapped
