"""Fingertip sensor channels over time with the detected contact intervals shaded."""
from __future__ import annotations

from typing import Sequence

import numpy as np

from reconstruction.figures.canvas import check_png_path, finite_array, new_figure, save_png

CONTACT_SHADE = dict(color="#f28e2b", alpha=0.25, linewidth=0)

#: Default time constant of the running pressure baseline, seconds (the pressure detector's default).
BASELINE_TIME_CONSTANT_S = 2.0


def contact_intervals(events, t_first_s: float, t_last_s: float) -> np.ndarray:
    """Pair contact start and end events into intervals.

    An interval runs from the start event's ``onset_t_s`` (first reading of the rise) to the end
    event's ``onset_t_s`` (first reading of the release). A contact still open at the end of the
    recording runs to ``t_last_s``; an end without a start (contact already on when the recording
    began) starts at ``t_first_s``.

    Parameters
    ----------
    events : sequence of sensor.contact_detection.ContactEvent
        In time order, kinds alternating start / end.
    t_first_s, t_last_s : float
        Time span of the recording, seconds.

    Returns
    -------
    (k, 2) float, (start, end) per contact, seconds.
    """
    intervals, open_since, previous_s = [], None, t_first_s
    for i, event in enumerate(events):
        kind, onset = getattr(event, "kind", None), getattr(event, "onset_t_s", None)
        if kind not in ("start", "end") or onset is None:
            raise ValueError(f"event {i} is not a ContactEvent (kind 'start'/'end' with onset_t_s): "
                             f"{event!r}")
        if not t_first_s <= onset <= t_last_s:
            raise ValueError(f"event {i} at {onset} s lies outside the readings' span "
                             f"{t_first_s} .. {t_last_s} s")
        if onset < previous_s:
            raise ValueError(f"event {i} at {onset} s comes before the previous event at {previous_s} s")
        previous_s = onset
        if kind == "start":
            if open_since is not None:
                raise ValueError(f"event {i} starts a contact at {onset} s while one is open since "
                                 f"{open_since} s; events must alternate start / end")
            open_since = onset
        elif open_since is None and i > 0:
            raise ValueError(f"event {i} ends a contact at {onset} s that never started; "
                             "events must alternate start / end")
        else:
            intervals.append((t_first_s if open_since is None else open_since, onset))
            open_since = None
    if open_since is not None:
        intervals.append((open_since, t_last_s))
    return np.array(intervals, float).reshape(-1, 2)


def running_baseline(t_s, pressure_pa, intervals_s, time_constant_s: float = BASELINE_TIME_CONSTANT_S
                     ) -> np.ndarray:
    """Pressure baseline that tracks drift while free and holds still during contacts.

    A time-weighted exponential moving average, ``b += (1 - exp(-dt / tau)) (p - b)``, started at
    the first pressure and frozen at readings inside a contact interval (the pressure detector's
    rule, so its events and this baseline agree).

    Parameters
    ----------
    t_s : (n,) float, seconds, non-decreasing
    pressure_pa : (n,) float, pascals
    intervals_s : (k, 2) float, contact (start, end) times, seconds
    time_constant_s : float, seconds (> 0)

    Returns
    -------
    (n,) float, pascals.
    """
    t = finite_array(t_s, "t_s", (None,))
    pressure = finite_array(pressure_pa, "pressure_pa", (len(t),))
    intervals = finite_array(intervals_s, "intervals_s", (None, 2))
    if not time_constant_s > 0:
        raise ValueError(f"time_constant_s must be > 0 s, got {time_constant_s}")
    if len(t) == 0:
        raise ValueError("no samples: t_s is empty")
    in_contact = np.zeros(len(t), bool)
    for start, end in intervals:
        in_contact |= (t >= start) & (t <= end)
    weights = -np.expm1(-np.diff(t, prepend=t[0]) / time_constant_s)
    baseline = np.empty(len(t))
    level = pressure[0]
    for k in range(len(t)):
        if not in_contact[k]:
            level += weights[k] * (pressure[k] - level)
        baseline[k] = level
    return baseline


def orientation_change_deg(quats_wxyz) -> np.ndarray:
    """Angle of each orientation from the first one, degrees in [0, 180]; sign-blind.

    Parameters
    ----------
    quats_wxyz : (n, 4) float, (w, x, y, z), need not be normalised
    """
    q = finite_array(quats_wxyz, "quats_wxyz", (None, 4))
    norms = np.linalg.norm(q, axis=1)
    if np.any(norms < 1e-9):
        raise ValueError(f"quaternions {np.flatnonzero(norms < 1e-9).tolist()[:10]} have zero length")
    q = q / norms[:, None]
    return np.degrees(2.0 * np.arccos(np.clip(np.abs(q @ q[0]), 0.0, 1.0)))


def sensor_traces_figure(readings: Sequence, events: Sequence, baseline_pa=None,
                         time_constant_s: float = BASELINE_TIME_CONSTANT_S):
    """The Figure of :func:`sensor_traces` (not written)."""
    t, pressure, quats, acc = _channels(readings)
    intervals = contact_intervals(events, t[0], t[-1])
    if baseline_pa is None:
        baseline = running_baseline(t, pressure, intervals, time_constant_s)
    else:
        baseline = finite_array(baseline_pa, "baseline_pa", (len(t),))
    t0 = t[0]
    series = [
        (np.linalg.norm(acc, axis=1), "|linear acc.| (m/s²)"),
        (orientation_change_deg(quats), "orientation change (°)"),
        (pressure - baseline, "pressure − baseline (Pa)"),
    ]
    figure = new_figure(10.0, 7.0, layout="constrained")
    axes = figure.subplots(len(series), 1, sharex=True)
    for ax, (values, label) in zip(axes, series):
        for i, (start, end) in enumerate(intervals):
            ax.axvspan(start - t0, end - t0, **CONTACT_SHADE, gid="contact-interval",
                       label="contact" if i == 0 else None)
        ax.plot(t - t0, values, color="#1f3b73", linewidth=1.0)
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("time (s)" if t0 == 0 else f"time (s) since t = {t0:.3f} s")
    axes[-1].set_xlim(0.0, max(t[-1] - t0, 1e-9))
    if len(intervals):
        axes[0].legend(loc="upper right", fontsize=9)
    figure.suptitle(f"Fingertip sensor: {len(t)} readings, {len(intervals)} detected contacts "
                    "(shaded)", fontsize=11)
    return figure


def sensor_traces(readings: Sequence, events: Sequence, path, baseline_pa=None,
                  time_constant_s: float = BASELINE_TIME_CONSTANT_S):
    """Write acceleration, orientation change and drift-compensated pressure against time.

    Three stacked panels: the magnitude of the linear acceleration (gravity removed), the angle of
    each reading's orientation from the first reading's (degrees), and the pressure minus a
    baseline (pascals). Detected contacts (:func:`contact_intervals`) are shaded in every panel.

    Parameters
    ----------
    readings : sequence of sensor.reading.Reading
        In time order (non-decreasing ``t_s``), at least one.
    events : sequence of sensor.contact_detection.ContactEvent
        Contact starts and ends detected in these readings (may be empty).
    path : str or Path
        PNG file to write.
    baseline_pa : (n,) float, optional
        Pressure baseline per reading, pascals; by default :func:`running_baseline` over the
        free segments.
    time_constant_s : float
        Time constant of the default baseline, seconds.

    Returns
    -------
    Path of the PNG written.
    """
    check_png_path(path)
    return save_png(sensor_traces_figure(readings, events, baseline_pa, time_constant_s), path)


def _channels(readings: Sequence):
    """Stack readings into t (n,), pressure (n,), quaternions (n, 4), linear acceleration (n, 3)."""
    readings = list(readings)
    if not readings:
        raise ValueError("no readings to plot (the sequence is empty)")
    try:
        t = np.array([r.t_s for r in readings], float)
        pressure = np.array([r.pressure_pa for r in readings], float)
        quats = np.array([np.asarray(r.quat_wxyz, float) for r in readings])
        acc = np.array([np.asarray(r.lin_acc_mps2, float) for r in readings])
    except (AttributeError, TypeError, ValueError) as exc:
        raise ValueError(f"readings must be sensor.reading.Reading records with (4,) quaternions "
                         f"and (3,) accelerations: {exc}") from exc
    t = finite_array(t, "reading times t_s", (None,))
    if np.any(np.diff(t) < 0):
        k = int(np.flatnonzero(np.diff(t) < 0)[0]) + 1
        raise ValueError(f"readings are not in time order: reading {k} at {t[k]} s follows {t[k - 1]} s")
    finite_array(pressure, "reading pressures pressure_pa", (len(t),))
    finite_array(quats, "reading quaternions quat_wxyz", (len(t), 4))
    finite_array(acc, "reading accelerations lin_acc_mps2", (len(t), 3))
    return t, pressure, quats, acc
