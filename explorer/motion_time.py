"""How long a touch is expected to take: the time model a strategy divides its information gain by.

A touch is a transfer (the arm from the previous standoff to the next; via the rest pose while the
stand turns, when the planner picks another stand pose), then the press (approach from the
standoff, contact, press, hold, retract). The constants are medians of recorded simulated sessions
(202 touches of registry and generated objects, ARMAR-III, ``datasheet-noise``; BENCHMARKS.md,
"Touch efficiency"): the press 3.5 s whatever the object, a same-pose transfer 0.7 s + 6.2 s per
metre between the targets, a stand change 1.95 s of arm motion. The simulated stand turns
instantly; a real turntable and tilt stage do not, so ``stand_turn_s_per_rad`` (an assumption:
30 deg/s) is added per radian turned.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class TouchTimeModel:
    """Per-touch time components, seconds (see the module docstring for their sources)."""

    press_s: float = 3.5
    transfer_s: float = 0.7
    transfer_s_per_m: float = 6.2
    stand_change_s: float = 1.95
    stand_turn_s_per_rad: float = 1.9


def _angle_between(a: float, b: float) -> float:
    return float(abs((a - b + np.pi) % (2 * np.pi) - np.pi))


class MotionTimeEstimator:
    """Expected seconds of candidate touches from where the arm and the stand are now.

    Parameters
    ----------
    planner : explorer.planner.ApproachPlanner or None
        Its ``pose_scores(approach)`` tells which stand pose a touch would use (the best-scored
        one); without it (a planner that has no reach map) every touch is taken to keep the pose.
    positioner : explorer.positioner.Positioner
    model : TouchTimeModel
    """

    def __init__(self, planner, positioner, model: TouchTimeModel = TouchTimeModel()):
        self._pose_scores = getattr(planner, "pose_scores", None)
        self.positioner = positioner
        self.model = model

    def time_s(self, targets_m: np.ndarray, approaches: np.ndarray, last_target_m: np.ndarray | None) -> np.ndarray:
        """(k,) expected seconds of touches at (k, 3) ``targets_m`` along (k, 3) ``approaches``
        (object frame), the previous touch having aimed at ``last_target_m`` (None: none yet)."""
        m = self.model
        targets_m = np.asarray(targets_m, float)
        current = self.positioner.pose()
        change = np.zeros(len(targets_m))
        if self._pose_scores is not None:
            for i, approach in enumerate(np.asarray(approaches, float)):
                scores = self._pose_scores(approach)
                pose = scores[0][1] if scores else current
                if pose != current:
                    turned = (_angle_between(pose.yaw_rad, current.yaw_rad)
                              + _angle_between(pose.tilt_rad, current.tilt_rad))
                    change[i] = m.stand_change_s + m.stand_turn_s_per_rad * turned
        if last_target_m is None:
            travel = np.zeros(len(targets_m))
        else:
            travel = np.linalg.norm(targets_m - np.asarray(last_target_m, float), axis=1)
        same_pose = m.transfer_s + m.transfer_s_per_m * travel
        return m.press_s + np.where(change > 0, change, same_pose)
