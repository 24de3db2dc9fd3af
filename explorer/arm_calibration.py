"""A lab's arm calibration applied to a run: fitted joint offsets and link lengths from a file.

``scripts/calibrate_joints.py`` writes ``joint_calibration.json`` for one simulated arm (robot,
profile, seed: the seed draws that arm's errors); :func:`read_arm_calibration` reads it back and
:func:`calibrated_arm` gives the robot and kinematics the loop then uses: encoder readings corrected
by the offsets (:class:`robots.joint_calibration.CalibratedRobot`) and forward kinematics with the
fitted link lengths (:func:`robots.link_lengths.with_link_length_errors`).
"""
from __future__ import annotations

import json
import math
import tempfile
import weakref
from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class ArmCalibration:
    """Fitted calibration of one arm.

    Attributes
    ----------
    robot, profile : str
    seed : int
        The run seed whose arm was calibrated (it draws the simulated arm's errors).
    offset_rad : (dof,) float
        Encoder reading minus true angle per joint, radians.
    link_length_error_m : dict of str -> float
        True minus nominal length per link joint, metres (empty: not fitted).
    """

    robot: str
    profile: str
    seed: int
    offset_rad: np.ndarray
    link_length_error_m: dict


def read_arm_calibration(path) -> ArmCalibration:
    """Read ``joint_calibration.json``; a missing file or field is a ValueError naming it."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        raise ValueError(f"calibration file not found: {path}") from None
    except json.JSONDecodeError as error:
        raise ValueError(f"{path}: not valid JSON: {error}") from None
    missing = [k for k in ("robot", "profile", "seed", "fitted_offset_deg") if k not in data]
    if missing:
        raise ValueError(f"{path}: missing {', '.join(missing)} (write it with scripts.calibrate_joints)")
    lengths = {k: 1e-3 * float(v) for k, v in (data.get("fitted_link_length_error_mm") or {}).items()}
    return ArmCalibration(str(data["robot"]), str(data["profile"]), int(data["seed"]),
                          np.radians(np.asarray(data["fitted_offset_deg"], float)), lengths)


def calibrated_arm(robot, kinematics, calibration: ArmCalibration):
    """(robot, kinematics) corrected by ``calibration``: readings minus the offsets, commands plus
    them, and the nominal model with the fitted link lengths."""
    from robots.joint_calibration import CalibratedRobot

    if not all(math.isfinite(v) for v in calibration.offset_rad):
        raise ValueError("calibration offsets must be finite")
    return CalibratedRobot(robot, calibration.offset_rad), with_fitted_link_lengths(kinematics,
                                                                                    calibration.link_length_error_m)


def with_fitted_link_lengths(kinematics, link_length_error_m: dict):
    """``kinematics`` with its links longer by ``link_length_error_m`` (joint name -> metres), or
    ``kinematics`` itself when there are none. A run's and its replay's model (the session's
    metadata keeps the calibration)."""
    from robots.kinematics import ArmKinematics
    from robots.link_lengths import with_link_length_errors

    if not any((link_length_error_m or {}).values()):
        return kinematics
    # the planner reads the URDF's collision shapes later: the directory lives as long as the model
    directory = tempfile.TemporaryDirectory(prefix="calibrated_arm_")
    corrected = ArmKinematics(with_link_length_errors(kinematics.spec, link_length_error_m, Path(directory.name)))
    weakref.finalize(corrected, directory.cleanup)
    return corrected
