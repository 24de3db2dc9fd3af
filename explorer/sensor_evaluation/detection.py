"""Contact detectors scored against the simulator's ground truth, on identical recorded readings.

Ground truth: the pad is in contact while the true normal force exceeds a small threshold; touches
separated by short gaps (bounces, chatter while aligning) form one contact. Every detector replays
the same recorded reading stream offline, from a fresh state, and each of its *start* events claims
a contact. A start is a true positive when it comes no earlier than a tolerance before an unclaimed
ground-truth contact begins and no later than ``max_latency_s`` after (nor more than the tolerance
after that contact ends); any other start is a false contact, including starts late in a long contact (a guarded move
would have pressed on long before) and starts on release. Toggling IMU
detectors (which cannot tell a start from an end) are scored on their start events the same way.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Iterable, Mapping

import numpy as np

from sensor.contact_detection import (AccelerationSpikeDetector, ContactDetector, OrientationChangeDetector,
                                      PressureContactDetector)
from explorer.sensor_evaluation.trials import TrialRecording

DEFAULT_DETECTORS: dict[str, Callable[[], ContactDetector]] = {
    "pressure": PressureContactDetector,
    "acceleration": AccelerationSpikeDetector,
    "orientation": OrientationChangeDetector,
}
"""The detectors compared, by name, as factories of fresh instances (default settings)."""


@dataclass(frozen=True)
class GroundTruthConfig:
    """How ground-truth contacts are cut from the force trace and matched.

    Attributes
    ----------
    force_threshold_n : float
        The pad touches while the true normal force exceeds this, newtons.
    merge_gap_s : float
        Touches closer together than this are one contact, seconds.
    tolerance_s : float
        A start event may come this much before a contact begins, seconds.
    max_latency_s : float
        A start event more than this after a contact began does not detect it, seconds. When the
        pad's edge meets a tilted or curved surface the force ramps slowly while the spring yields
        (0.05 -> 0.2 N can take a second at 0.5 mm/s), so the default leaves room for that.
    """

    force_threshold_n: float = 0.05
    merge_gap_s: float = 0.1
    tolerance_s: float = 0.05
    max_latency_s: float = 2.0

    def __post_init__(self) -> None:
        if not self.force_threshold_n > 0.0:
            raise ValueError(f"force_threshold_n must be > 0 N, got {self.force_threshold_n}")
        if not (self.merge_gap_s >= 0.0 and self.tolerance_s >= 0.0 and self.max_latency_s > 0.0):
            raise ValueError("merge_gap_s and tolerance_s must be >= 0 s, max_latency_s > 0 s")


def contact_intervals(t_s, force_n, threshold_n: float, merge_gap_s: float = 0.0) -> np.ndarray:
    """Ground-truth contacts: spans where ``force_n > threshold_n``, short gaps merged.

    Parameters
    ----------
    t_s : (n,) float
        Sample times, seconds, increasing.
    force_n : (n,) float
        True normal force, newtons.
    threshold_n : float
        Contact force threshold, newtons.
    merge_gap_s : float
        Spans separated by less than this are merged, seconds.

    Returns
    -------
    (k, 2) float, (first, last) sample time above threshold per contact, seconds.
    """
    t = np.asarray(t_s, dtype=float)
    force = np.asarray(force_n, dtype=float)
    if t.ndim != 1 or force.shape != t.shape:
        raise ValueError(f"t_s and force_n must be equal-length 1-D arrays, got {t.shape} and {force.shape}")
    if np.any(np.diff(t) <= 0.0):
        raise ValueError("t_s must be strictly increasing")
    touching = np.concatenate([[False], force > threshold_n, [False]])
    edges = np.flatnonzero(np.diff(touching.astype(int)))
    starts, stops = edges[0::2], edges[1::2] - 1
    intervals: list[list[float]] = []
    for first, last in zip(t[starts], t[stops]):
        if intervals and first - intervals[-1][1] < merge_gap_s:
            intervals[-1][1] = last
        else:
            intervals.append([first, last])
    return np.array(intervals, dtype=float).reshape(-1, 2)


@dataclass(frozen=True)
class MatchResult:
    """Start events of one detector against the ground-truth contacts of one recording.

    Attributes
    ----------
    detected : int
        Ground-truth contacts claimed by a start event.
    missed : int
        Ground-truth contacts no start event claimed.
    false_starts : int
        Start events that claim no (unclaimed) ground-truth contact.
    latencies_s : (detected,) float
        Start event time minus contact start, seconds.
    """

    detected: int
    missed: int
    false_starts: int
    latencies_s: np.ndarray = field(repr=False)


def match_starts(start_times_s, intervals_s, tolerance_s: float, max_latency_s: float) -> MatchResult:
    """Pair start events with ground-truth contacts (see the module docstring).

    Parameters
    ----------
    start_times_s : (m,) float
        Start event times, seconds.
    intervals_s : (k, 2) float
        Ground-truth contacts (begin, end), seconds.
    tolerance_s, max_latency_s : float
        A start at ``t`` can claim a contact when ``begin - tolerance_s <= t <= begin + max_latency_s``
        and ``t <= end + tolerance_s``.
    """
    intervals = np.asarray(intervals_s, dtype=float).reshape(-1, 2)
    claimed = np.zeros(len(intervals), dtype=bool)
    latencies, false_starts = [], 0
    for t in sorted(float(x) for x in start_times_s):
        begin, end = intervals[:, 0], intervals[:, 1]
        inside = np.flatnonzero((begin - tolerance_s <= t) & (t <= np.minimum(begin + max_latency_s, end + tolerance_s))
                                & ~claimed)
        if len(inside) == 0:
            false_starts += 1
            continue
        claimed[inside[0]] = True
        latencies.append(t - intervals[inside[0], 0])
    return MatchResult(int(claimed.sum()), int((~claimed).sum()), false_starts, np.array(latencies))


@dataclass(frozen=True)
class DetectorScore:
    """One detector over all recordings.

    Attributes
    ----------
    contacts : int
        Ground-truth contacts in the press trials.
    detected : int
    missed : int
    false_contacts : int
        Unclaimed start events in press trials (during approach, retreat, or duplicates).
    false_contacts_free_motion : int
        Start events during the free-motion trials (nothing to touch there).
    median_latency_s, p90_latency_s : float
        Median and 90th percentile of the delay from contact start to the start event, seconds
        (nan if none detected).
    """

    contacts: int
    detected: int
    missed: int
    false_contacts: int
    false_contacts_free_motion: int
    median_latency_s: float
    p90_latency_s: float

    @property
    def recall(self) -> float:
        """Detected / ground-truth contacts (nan without contacts)."""
        return self.detected / self.contacts if self.contacts else math.nan

    @property
    def precision(self) -> float:
        """Detected / all start events, free motion included (nan without any start event)."""
        claimed = self.detected + self.false_contacts + self.false_contacts_free_motion
        return self.detected / claimed if claimed else math.nan


def replay(detector: ContactDetector, readings: Iterable) -> list[float]:
    """Times of the start events ``detector`` (reset first) confirms on ``readings``, seconds."""
    detector.reset()
    return [event.t_s for event in detector.process(readings) if event.kind == "start"]


def score_detectors(recordings: Iterable[TrialRecording], stream: str,
                    detectors: Mapping[str, Callable[[], ContactDetector]] | None = None,
                    ground_truth: GroundTruthConfig = GroundTruthConfig()) -> dict[str, DetectorScore]:
    """Replay ``stream`` of every recording through every detector and score the start events.

    Parameters
    ----------
    recordings : iterable of TrialRecording
        Press and free-motion trials.
    stream : str
        Which sensor variant's readings to replay (a key of ``TrialRecording.streams``).
    detectors : mapping of name -> factory, optional
        Default :data:`DEFAULT_DETECTORS`.
    ground_truth : GroundTruthConfig

    Raises
    ------
    ValueError
        If a recording lacks ``stream``.
    """
    detectors = dict(DEFAULT_DETECTORS if detectors is None else detectors)
    totals = {name: dict(contacts=0, detected=0, missed=0, false=0, free=0, latencies=[]) for name in detectors}
    for recording in recordings:
        if stream not in recording.streams:
            raise ValueError(f"recording has no sensor stream {stream!r}; it has {sorted(recording.streams)}")
        readings = recording.streams[stream]
        intervals = contact_intervals(recording.force_t_s, recording.normal_force_n,
                                      ground_truth.force_threshold_n, ground_truth.merge_gap_s)
        for name, factory in detectors.items():
            result = match_starts(replay(factory(), readings), intervals, ground_truth.tolerance_s,
                                  ground_truth.max_latency_s)
            total = totals[name]
            total["contacts"] += len(intervals)
            total["detected"] += result.detected
            total["missed"] += result.missed
            total["free" if recording.kind == "free" else "false"] += result.false_starts
            total["latencies"].extend(result.latencies_s.tolist())
    return {
        name: DetectorScore(t["contacts"], t["detected"], t["missed"], t["false"], t["free"],
                            *(np.percentile(t["latencies"], [50, 90]).tolist() if t["latencies"] else [math.nan] * 2))
        for name, t in totals.items()
    }
