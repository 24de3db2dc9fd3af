"""The robot interface the exploration loop depends on (simulation and hardware alike)."""
from __future__ import annotations

import abc
from dataclasses import dataclass
from typing import Callable

import numpy as np


class MoveNotReachedError(RuntimeError):
    """A move ended away from its target (blocked by a contact, or too slow to settle).

    Attributes
    ----------
    body : str or None
        What the arm met, when the robot knows (the simulator names the body, e.g. ``"table"`` or
        the object's name); None otherwise (a real arm's controller only reports the stop).
    link : str or None
        The arm's link that met it, when known.
    """

    def __init__(self, message: str, *, body: str | None = None, link: str | None = None):
        super().__init__(message)
        self.body = body
        self.link = link


@dataclass(frozen=True)
class GuardedMoveResult:
    """Outcome of :meth:`Robot.guarded_move`.

    Attributes
    ----------
    stopped : bool
        True when the ``stop`` predicate fired before the path ended.
    q : (dof,) float
        Joint positions (radians) where the motion ended.
    waypoint_index : int
        Index of the path waypoint being tracked when the motion ended.
    """

    stopped: bool
    q: np.ndarray
    waypoint_index: int


class Robot(abc.ABC):
    """An arm that reports joint positions and moves; simulated or real."""

    @property
    @abc.abstractmethod
    def dof(self) -> int:
        """Number of actuated joints."""

    @abc.abstractmethod
    def joint_positions(self) -> np.ndarray:
        """Actuated joint positions as encoders report them, (dof,) float, radians."""

    @abc.abstractmethod
    def move_joints(self, q: np.ndarray, speed_rad_s: float = 1.0) -> None:
        """Move to ``q`` ((dof,) radians) and return when reached."""

    @abc.abstractmethod
    def guarded_move(
        self, path: np.ndarray, stop: Callable[[], bool], speed_rad_s: float = 0.2
    ) -> GuardedMoveResult:
        """Follow ``path`` ((k, dof) radians), calling ``stop()`` every control tick.

        Halts (holding position) as soon as ``stop()`` returns True.
        """

    @abc.abstractmethod
    def hold(self, duration_s: float, stop: Callable[[], bool] | None = None) -> GuardedMoveResult:
        """Keep the current position for ``duration_s`` seconds, calling ``stop()`` every tick.

        Returns early (``stopped=True``) when ``stop()`` returns True. The exploration loop holds
        a press this way while the spring aligns the pad.
        """

    @abc.abstractmethod
    def time_s(self) -> float:
        """The robot's clock, seconds (simulation time or host monotonic time)."""


def checked_joint_positions(q, name: str, joint_names, lower_rad, upper_rad) -> np.ndarray:
    """``q`` as a float array, or a ValueError naming every joint outside its limits.

    Parameters
    ----------
    q : (dof,) float, radians
    name : str
        What ``q`` is, for the message (``"path[3]"``).
    joint_names : sequence of str
    lower_rad, upper_rad : (dof,) float
    """
    q = np.asarray(q, dtype=float)
    dof = len(joint_names)
    if q.shape != (dof,) or not np.all(np.isfinite(q)):
        raise ValueError(f"{name} must be {dof} finite joint angles (rad), got shape {q.shape}")
    outside = [
        f"{joint} = {np.degrees(v):.2f} deg not in [{np.degrees(lo):.2f}, {np.degrees(hi):.2f}]"
        for joint, v, lo, hi in zip(joint_names, q, lower_rad, upper_rad)
        if not lo - 1e-9 <= v <= hi + 1e-9
    ]
    if outside:
        raise ValueError(f"{name} is outside the joint limits: " + "; ".join(outside))
    return q
