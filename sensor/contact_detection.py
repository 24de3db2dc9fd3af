"""Contact detection from a stream of Readings: pure logic, the same for simulation and hardware.

A :class:`ContactDetector` consumes readings one by one and emits :class:`ContactEvent` records when
a contact starts or ends. :class:`PressureContactDetector` is the one the exploration uses: the pad's
pressure rise over a drift-tracking baseline. :class:`AccelerationSpikeDetector` and
:class:`OrientationChangeDetector` watch the IMU instead and exist for comparison.
"""
from __future__ import annotations

import abc
import math
from collections import deque
from dataclasses import dataclass
from typing import Iterable, Literal

import numpy as np

from sensor.reading import Reading
from common.rotations import angle_between_rad


@dataclass(frozen=True)
class ContactEvent:
    """A contact start or end.

    Attributes
    ----------
    kind : {'start', 'end'}
        Which transition.
    t_s : float
        Time of the reading that confirmed the transition, seconds.
    onset_t_s : float
        Time of the first reading of the transition (before any confirmation delay), seconds.
    signal : float
        The detector's signal at confirmation: Pa above baseline (pressure), m/s^2 (acceleration
        step) or radians (orientation change).
    baseline_pa : float or None
        Pressure baseline frozen at the transition, pascals; None for IMU detectors.
    """

    kind: Literal["start", "end"]
    t_s: float
    onset_t_s: float
    signal: float
    baseline_pa: float | None = None


class ContactDetector(abc.ABC):
    """Turns readings, fed in time order, into contact start / end events."""

    @property
    @abc.abstractmethod
    def in_contact(self) -> bool:
        """True between a start event and the following end event."""

    @abc.abstractmethod
    def update(self, reading: Reading) -> ContactEvent | None:
        """Consume one reading; return the event it confirms, if any."""

    @abc.abstractmethod
    def reset(self) -> None:
        """Forget all history (as if newly constructed)."""

    def process(self, readings: Iterable[Reading]) -> list[ContactEvent]:
        """Feed several readings; return their events in order."""
        return [event for event in map(self.update, readings) if event is not None]


def _check_time(reading: Reading, last_t: float | None) -> None:
    if not math.isfinite(reading.t_s):
        raise ValueError(f"reading time must be finite, got {reading.t_s}")
    if last_t is not None and reading.t_s < last_t:
        raise ValueError(f"reading time {reading.t_s} s is earlier than the previous {last_t} s")


@dataclass(frozen=True)
class PressureDetectorConfig:
    """Thresholds and timings of :class:`PressureContactDetector`.

    With the default BMP280 setting (x4 oversampling, IIR off: 2.1 Pa RMS, 83 Hz) the start threshold
    is ~50 noise RMS, and the default pad reaches it at ~0.17 N.

    Attributes
    ----------
    start_threshold_pa : float
        Pressure above baseline that starts a contact, pascals.
    end_threshold_pa : float
        Pressure above baseline below which a contact ends, pascals (< start: hysteresis).
    min_start_duration_s : float
        How long the pressure must stay above the start threshold before the start is confirmed, s.
    min_end_duration_s : float
        How long it must stay below the end threshold before the end is confirmed, seconds.
    baseline_time_constant_s : float
        Time constant of the exponential moving average that tracks drift while free, seconds.
    baseline_hold_pa : float or None
        While the rise is above this (a press beginning, below the start threshold), the baseline
        follows it only with ``held_baseline_time_constant_s``: a pad meeting a tilted surface
        through a soft pad loads up over a second or more, and a 2 s average would absorb a good part
        of that rise into the baseline and confirm the contact late or never. Drift (ambient pressure,
        the bubble's temperature: below 1 Pa/s) stays within the band. None: the whole rise is
        tracked (the detector before this setting existed; replays of older sessions use it).
    held_baseline_time_constant_s : float
        Time constant of the baseline while the rise is above ``baseline_hold_pa``, seconds: slow,
        so that a rise that stays (an upward drift step) is still followed eventually.
    """

    start_threshold_pa: float = 100.0
    end_threshold_pa: float = 50.0
    min_start_duration_s: float = 0.02
    min_end_duration_s: float = 0.01
    baseline_time_constant_s: float = 2.0
    baseline_hold_pa: float | None = 20.0
    held_baseline_time_constant_s: float = 30.0

    def __post_init__(self) -> None:
        if not self.start_threshold_pa > 0.0:
            raise ValueError(f"start_threshold_pa must be > 0 Pa, got {self.start_threshold_pa}")
        if not 0.0 < self.end_threshold_pa <= self.start_threshold_pa:
            raise ValueError(
                f"end_threshold_pa must be in (0, start_threshold_pa={self.start_threshold_pa}] Pa, "
                f"got {self.end_threshold_pa}"
            )
        if not (self.min_start_duration_s >= 0.0 and self.min_end_duration_s >= 0.0):
            raise ValueError("min_start_duration_s and min_end_duration_s must be >= 0 s")
        if not self.baseline_time_constant_s > 0.0:
            raise ValueError(f"baseline_time_constant_s must be > 0 s, got {self.baseline_time_constant_s}")
        if self.baseline_hold_pa is not None and not 0.0 < self.baseline_hold_pa <= self.start_threshold_pa:
            raise ValueError(f"baseline_hold_pa must be None or in (0, start_threshold_pa="
                             f"{self.start_threshold_pa}] Pa, got {self.baseline_hold_pa}")
        if not self.held_baseline_time_constant_s >= self.baseline_time_constant_s:
            raise ValueError(f"held_baseline_time_constant_s must be >= baseline_time_constant_s "
                             f"({self.baseline_time_constant_s} s), got {self.held_baseline_time_constant_s}")


class PressureContactDetector(ContactDetector):
    """Contact from the pressure rise over a drift-compensating baseline, with hysteresis.

    While free, the baseline follows the pressure with an exponential moving average (time-weighted,
    so sample-and-hold repeats do not bias it); once the rise passes ``baseline_hold_pa`` it follows
    only slowly, so a slowly loading press is not absorbed into it. It freezes as soon as the rise
    crosses the start threshold and stays frozen during the contact, so a press cannot drag it up. A start is confirmed
    once the rise has stayed above ``start_threshold_pa`` for ``min_start_duration_s``; an end once it
    has stayed below ``end_threshold_pa`` for ``min_end_duration_s``. The first reading initialises
    the baseline, so start the detector while the pad is free.
    """

    def __init__(self, config: PressureDetectorConfig | None = None) -> None:
        self.config = config if config is not None else PressureDetectorConfig()
        self.reset()

    def reset(self) -> None:
        self._baseline_pa: float | None = None
        self._in_contact = False
        self._pending_since_s: float | None = None
        self._last_t: float | None = None

    @property
    def in_contact(self) -> bool:
        return self._in_contact

    @property
    def baseline_pa(self) -> float | None:
        """Current pressure baseline, pascals (None before the first reading)."""
        return self._baseline_pa

    def rise_pa(self, reading: Reading) -> float:
        """Pressure of ``reading`` above the current baseline, pascals."""
        if self._baseline_pa is None:
            raise ValueError("no baseline yet: feed at least one reading first")
        return reading.pressure_pa - self._baseline_pa

    def update(self, reading: Reading) -> ContactEvent | None:
        _check_time(reading, self._last_t)
        if not math.isfinite(reading.pressure_pa):
            raise ValueError(f"reading pressure must be finite, got {reading.pressure_pa}")
        dt = 0.0 if self._last_t is None else reading.t_s - self._last_t
        self._last_t = reading.t_s
        if self._baseline_pa is None:
            self._baseline_pa = reading.pressure_pa
            return None
        rise = reading.pressure_pa - self._baseline_pa
        cfg = self.config
        if self._in_contact:
            return self._confirm(reading, rise, rise < cfg.end_threshold_pa, cfg.min_end_duration_s, "end")
        event = self._confirm(reading, rise, rise > cfg.start_threshold_pa, cfg.min_start_duration_s, "start")
        if event is None and self._pending_since_s is None:
            held = cfg.baseline_hold_pa is not None and rise > cfg.baseline_hold_pa
            tau = cfg.held_baseline_time_constant_s if held else cfg.baseline_time_constant_s
            self._baseline_pa += -math.expm1(-dt / tau) * rise
        return event

    def _confirm(self, reading: Reading, rise: float, beyond: bool, min_duration_s: float,
                 kind: Literal["start", "end"]) -> ContactEvent | None:
        if not beyond:
            self._pending_since_s = None
            return None
        if self._pending_since_s is None:
            self._pending_since_s = reading.t_s
        if reading.t_s - self._pending_since_s < min_duration_s:
            return None
        onset = self._pending_since_s
        self._pending_since_s = None
        self._in_contact = kind == "start"
        return ContactEvent(kind=kind, t_s=reading.t_s, onset_t_s=onset, signal=rise, baseline_pa=self._baseline_pa)


class _SpikeToggleDetector(ContactDetector):
    """Shared logic of the IMU detectors: each spike of a signal toggles contact (start, end, ...).

    An IMU sees the impact of touching and the jolt of releasing but nothing in between, so the
    first spike while free starts a contact and the next one ends it. After each event the signal
    must fall back below the threshold and ``refractory_s`` must pass before another event.
    """

    def __init__(self, threshold: float, refractory_s: float) -> None:
        if not threshold > 0.0:
            raise ValueError(f"threshold must be > 0, got {threshold}")
        if not refractory_s >= 0.0:
            raise ValueError(f"refractory_s must be >= 0 s, got {refractory_s}")
        self.threshold = threshold
        self.refractory_s = refractory_s
        self.reset()

    def reset(self) -> None:
        self._in_contact = False
        self._armed = True
        self._last_event_t: float | None = None
        self._last_t: float | None = None
        self._reset_signal()

    @property
    def in_contact(self) -> bool:
        return self._in_contact

    def update(self, reading: Reading) -> ContactEvent | None:
        _check_time(reading, self._last_t)
        self._last_t = reading.t_s
        signal = self._signal(reading)
        if signal <= self.threshold:
            self._armed = True
            return None
        refractory = self._last_event_t is not None and reading.t_s - self._last_event_t < self.refractory_s
        if not self._armed or refractory:
            return None
        self._armed = False
        self._last_event_t = reading.t_s
        self._in_contact = not self._in_contact
        return ContactEvent(kind="start" if self._in_contact else "end", t_s=reading.t_s,
                            onset_t_s=reading.t_s, signal=signal)

    @abc.abstractmethod
    def _reset_signal(self) -> None:
        """Forget the signal's history."""

    @abc.abstractmethod
    def _signal(self, reading: Reading) -> float:
        """The detector's signal for this reading."""


class AccelerationSpikeDetector(_SpikeToggleDetector):
    """Contact from a step in the linear acceleration between consecutive readings.

    Signal: ``|lin_acc(k) - lin_acc(k-1)|``, m/s^2 (a jerk spike, not divided by time so that
    sample-and-hold repeats neither dilute nor inflate it). The BNO055's per-sample noise is about
    0.012 m/s^2 per axis, so the default 0.3 m/s^2 sits far above it; a slow guarded approach may
    still touch too gently to be seen.

    Parameters
    ----------
    threshold_mps2 : float
        Acceleration step that counts as a spike, m/s^2.
    refractory_s : float
        Dead time after an event, seconds.
    """

    def __init__(self, threshold_mps2: float = 0.3, refractory_s: float = 0.1) -> None:
        super().__init__(threshold_mps2, refractory_s)

    def _reset_signal(self) -> None:
        self._previous_acc: np.ndarray | None = None

    def _signal(self, reading: Reading) -> float:
        acc = np.asarray(reading.lin_acc_mps2, dtype=float)
        if acc.shape != (3,) or not np.all(np.isfinite(acc)):
            raise ValueError(f"reading lin_acc_mps2 must be 3 finite numbers, got {reading.lin_acc_mps2!r}")
        previous, self._previous_acc = self._previous_acc, acc
        return 0.0 if previous is None else float(np.linalg.norm(acc - previous))


class OrientationChangeDetector(_SpikeToggleDetector):
    """Contact from the pad turning as it aligns with a surface.

    Signal: angle between the current orientation and the one ``window_s`` earlier, radians. The
    arm's own rotations trigger it too, so it only suits motions that keep the fingertip's
    orientation fixed while approaching.

    Parameters
    ----------
    threshold_rad : float
        Orientation change that counts as a contact, radians (default 2 degrees).
    window_s : float
        Look-back time, seconds.
    refractory_s : float
        Dead time after an event, seconds.
    """

    def __init__(self, threshold_rad: float = math.radians(2.0), window_s: float = 0.1,
                 refractory_s: float = 0.2) -> None:
        if not window_s > 0.0:
            raise ValueError(f"window_s must be > 0 s, got {window_s}")
        self.window_s = window_s
        super().__init__(threshold_rad, refractory_s)

    def _reset_signal(self) -> None:
        self._history: deque[tuple[float, np.ndarray]] = deque()

    def _signal(self, reading: Reading) -> float:
        quat = np.asarray(reading.quat_wxyz, dtype=float)
        if quat.shape != (4,) or not np.all(np.isfinite(quat)) or not np.linalg.norm(quat) > 0.0:
            raise ValueError(f"reading quat_wxyz must be 4 finite numbers, not all zero, got {reading.quat_wxyz!r}")
        self._history.append((reading.t_s, quat))
        horizon = reading.t_s - self.window_s
        while len(self._history) > 1 and self._history[1][0] <= horizon:
            self._history.popleft()
        return angle_between_rad(self._history[0][1], quat)
