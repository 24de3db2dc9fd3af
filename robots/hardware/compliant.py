"""The arm in the robot's own compliant mode: a person moves it, the framework only reads it.

For human-guided exploration on hardware (the robot's gravity-compensated, low-impedance mode is
switched on with the vendor's tools). Wraps a connected arm; reads its encoders on its control
clock and refuses every motion command, so nothing here can fight the person guiding the arm.
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from robots.interface import GuardedMoveResult, Robot


class CompliantModeError(RuntimeError):
    """A motion was commanded while the arm is guided by hand."""


class CompliantArm(Robot):
    """Read-only view of a hardware arm (``robots.hardware.HardwareArm`` or any arm with
    ``joint_positions()``, ``time_s()``, ``sleep(s)`` and ``control_period_s``).

    :meth:`hold` waits, reading the encoders every control period, without sending targets.
    """

    def __init__(self, arm):
        self.arm = arm

    @property
    def dof(self) -> int:
        return self.arm.dof

    def joint_positions(self) -> np.ndarray:
        return self.arm.joint_positions()

    def time_s(self) -> float:
        return self.arm.time_s()

    def hold(self, duration_s: float, stop: Callable[[], bool] | None = None) -> GuardedMoveResult:
        if not duration_s >= 0.0:
            raise ValueError(f"duration_s must be >= 0, got {duration_s}")
        t0 = self.time_s()
        while self.time_s() - t0 < duration_s:
            if stop is not None and stop():
                return GuardedMoveResult(stopped=True, q=self.joint_positions(), waypoint_index=0)
            self.arm.sleep(self.arm.control_period_s)
        return GuardedMoveResult(stopped=False, q=self.joint_positions(), waypoint_index=0)

    def move_joints(self, q, speed_rad_s: float = 1.0) -> None:
        raise CompliantModeError("the arm is in compliant mode (guided by hand): move_joints is refused")

    def guarded_move(self, path, stop, speed_rad_s: float = 0.2) -> GuardedMoveResult:
        raise CompliantModeError("the arm is in compliant mode (guided by hand): guarded_move is refused")
