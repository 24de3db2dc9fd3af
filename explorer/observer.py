"""Watching a run as it happens: the :class:`RunObserver` interface and the strategy tap.

The :class:`explorer.recording.RunRecorder` already sees every reading, joint state, touch and event
of a run; it forwards each to its observer, on the session clock (device time + the resume
offset). The one thing the recorder does not see, the strategy's suggested next touch, comes from
:class:`ObservedStrategy`, a pass-through wrapper around the run's strategy. An observer must not
change the run: it only reads what it is given.
"""
from __future__ import annotations

from typing import Callable

import numpy as np


class RunObserver:
    """Receives what a run sees; every method is a no-op (subclass and override what you need).

    Times are session-clock seconds (simulated or device clock, plus the resume offset).
    """

    def run_started(self, rig, gpis, metadata: dict) -> None:
        """Before the first touch. ``rig``: :class:`explorer.run.Rig` (robot, kinematics, positioner,
        reference mesh); ``gpis``: the run's GPIS, filled as the run goes (object frame)."""

    def readings(self, readings: list) -> None:
        """New sensor readings (:class:`sensor.reading.Reading`)."""

    def joint_state(self, t_s: float, q: np.ndarray) -> None:
        """The arm's joint positions (radians) at ``t_s``."""

    def touch(self, record, t_s: float) -> None:
        """A finished touch (:class:`explorer.loop.TouchRecord`, object frame), after the GPIS took it."""

    def suggestion(self, touch, t_s: float) -> None:
        """The strategy's best proposal for the next touch (:class:`explorer.touch.Touch`)."""

    def event(self, kind: str, t_s: float, fields: dict) -> None:
        """Any other session event (``contact_start``, ``stopped``, ``resumed``, ...)."""

    def reconstruction(self, mesh, n_contacts: int, t_s: float) -> None:
        """The final GPIS mean surface (object frame)."""

    def close(self) -> None:
        """The run ended (also after an error); flush and release what the observer holds."""


class ObservedStrategy:
    """A strategy that tells ``observer`` its best proposal, otherwise the wrapped strategy itself.

    Parameters
    ----------
    strategy : explorer.strategies.TouchStrategy
    observer : RunObserver
    clock : callable () -> float
        The session clock, seconds.
    """

    def __init__(self, strategy, observer: RunObserver, clock: Callable[[], float]):
        self._strategy = strategy
        self._observer = observer
        self._clock = clock

    def propose(self, state, count: int) -> list:
        proposals = self._strategy.propose(state, count)
        if proposals:
            self._observer.suggestion(proposals[0], self._clock())
        return proposals

    def __getattr__(self, name: str):  # name, accepted(), ...: as the wrapped strategy has them
        return getattr(self._strategy, name)
