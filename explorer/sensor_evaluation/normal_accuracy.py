"""Surface-normal error of settled presses, per tilt of the touched plane and per sensor variant.

Each press's normal is estimated the way the exploration loop does it: the pressure detector, replayed
on the variant's readings, gives the free-pad baseline, and :func:`sensor.normal_estimation.estimate_normal`
averages the orientation over the first steady window of the hold (the arm stands still, the spring
settles). The error is the angle to the true outward normal of the plane.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from sensor.contact_detection import PressureContactDetector
from explorer.sensor_evaluation.trials import TrialRecording
from sensor.normal_estimation import NormalEstimate, OrientationNotSettledError, SettlingConfig, estimate_normal


def angle_deg(u, v) -> float:
    """Angle between two 3-vectors, degrees."""
    u, v = np.asarray(u, dtype=float), np.asarray(v, dtype=float)
    return math.degrees(math.atan2(np.linalg.norm(np.cross(u, v)), float(u @ v)))


def estimate_press_normal(recording: TrialRecording, stream: str,
                          settling: SettlingConfig | None = None) -> NormalEstimate | None:
    """The normal a loop would report for this press from ``stream``; None if it never settled.

    Raises
    ------
    ValueError
        For a recording that is not a press, or without ``stream``, or whose readings hold no
        contact start (the pressure detector never fired: a missed contact, not a normal error).
    """
    if recording.press is None:
        raise ValueError("only press recordings have a normal to estimate")
    if stream not in recording.streams:
        raise ValueError(f"recording has no sensor stream {stream!r}; it has {sorted(recording.streams)}")
    outcome = recording.press
    readings = recording.streams[stream]
    detector = PressureContactDetector()
    start = next((e for e in detector.process(r for r in readings if r.t_s <= outcome.hold_end_s)
                  if e.kind == "start"), None)
    if start is None:
        raise ValueError(f"no contact start in stream {stream!r} of this press: nothing to estimate")
    hold = [r for r in readings if outcome.hold_start_s <= r.t_s <= outcome.hold_end_s]
    try:
        return estimate_normal(hold, start.baseline_pa, settling=settling)
    except OrientationNotSettledError:
        return None


@dataclass(frozen=True)
class NormalTrial:
    """One press of the normal experiment.

    Attributes
    ----------
    tilt_deg, azimuth_deg : float
        Tilt of the plane from facing the approach, and its direction about the approach axis.
    held_force_n : float
        Mean true force over the hold, newtons.
    body_misalignment_deg : float
        True angle between the pad's face axis and the reversed normal at the end of the hold.
    errors_deg : dict of str -> float
        Normal error per sensor variant, degrees (nan: the orientation never settled).
    """

    tilt_deg: float
    azimuth_deg: float
    held_force_n: float
    body_misalignment_deg: float
    errors_deg: dict[str, float] = field(repr=False)


def normal_trial(recording: TrialRecording, streams: Sequence[str]) -> NormalTrial:
    """Errors of one press recording for each variant in ``streams``."""
    outcome = recording.press
    if outcome is None:
        raise ValueError("only press recordings have a normal to estimate")
    errors = {}
    for stream in streams:
        estimate = estimate_press_normal(recording, stream)
        errors[stream] = math.nan if estimate is None else angle_deg(estimate.normal, outcome.true_normal)
    return NormalTrial(math.degrees(outcome.spec.tilt_rad), math.degrees(outcome.spec.azimuth_rad),
                       outcome.held_force_n, math.degrees(outcome.body_misalignment_rad), errors)


@dataclass(frozen=True)
class NormalAccuracy:
    """RMSE of the normal per tilt and sensor variant.

    Attributes
    ----------
    tilts_deg : (t,) float
        The tilts, increasing, degrees.
    rmse_deg : dict of str -> (t,) float
        Root-mean-square normal error per tilt, per variant, degrees (over settled presses).
    unsettled : dict of str -> (t,) int
        Presses per tilt and variant whose orientation never settled (left out of the RMSE).
    body_rmse_deg : (t,) float
        RMS of the true pad misalignment per tilt (what the spring and contact achieved), degrees.
    trials : tuple of NormalTrial
    rmse_ci95_deg : dict of str -> (t, 2) float
        95 % bootstrap interval (percentile, resampling the presses of each tilt) of each RMSE,
        degrees: whether two tilts' RMSEs differ by more than the presses' scatter.
    """

    tilts_deg: np.ndarray
    rmse_deg: dict[str, np.ndarray]
    unsettled: dict[str, np.ndarray]
    body_rmse_deg: np.ndarray
    trials: tuple[NormalTrial, ...] = field(repr=False)
    rmse_ci95_deg: dict[str, np.ndarray] = field(default_factory=dict, repr=False)

    def mean_deg(self, stream: str) -> float:
        """Mean over tilts of the per-tilt RMSE, degrees."""
        return float(np.mean(self.rmse_deg[stream]))


def summarize(trials: Sequence[NormalTrial]) -> NormalAccuracy:
    """Per-tilt RMSE over ``trials`` (all with the same variants)."""
    trials = tuple(trials)
    if not trials:
        raise ValueError("no normal trials to summarize")
    streams = list(trials[0].errors_deg)
    tilts = np.unique([t.tilt_deg for t in trials])
    rmse, unsettled, intervals = {}, {}, {}
    for stream in streams:
        values, missing, cis = [], [], []
        for tilt in tilts:
            errors = np.array([t.errors_deg[stream] for t in trials if t.tilt_deg == tilt])
            settled = errors[np.isfinite(errors)]
            values.append(math.sqrt(float(np.mean(settled**2))) if len(settled) else math.nan)
            missing.append(len(errors) - len(settled))
            cis.append(bootstrap_rmse_ci(settled))
        rmse[stream] = np.array(values)
        unsettled[stream] = np.array(missing, dtype=int)
        intervals[stream] = np.array(cis).reshape(-1, 2)
    body = np.array([math.sqrt(float(np.mean([t.body_misalignment_deg**2 for t in trials if t.tilt_deg == tilt])))
                     for tilt in tilts])
    return NormalAccuracy(tilts, rmse, unsettled, body, trials, intervals)


def bootstrap_rmse_ci(errors_deg, level: float = 0.95, resamples: int = 2000, seed: int = 0) -> tuple[float, float]:
    """Percentile bootstrap interval of the RMS of ``errors_deg`` ((n,) float), same units.

    Seeded, so a report is reproducible; (nan, nan) for fewer than two values.
    """
    errors = np.asarray(errors_deg, dtype=float)
    if len(errors) < 2:
        return (math.nan, math.nan)
    rng = np.random.default_rng(seed)
    samples = errors[rng.integers(0, len(errors), size=(resamples, len(errors)))]
    rms = np.sqrt(np.mean(samples**2, axis=1))
    low, high = np.percentile(rms, [50 * (1 - level), 100 - 50 * (1 - level)])
    return (float(low), float(high))
