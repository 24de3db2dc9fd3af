"""The evaluation's results as a JSON-ready dict, a plain-text table and PNG figures."""
from __future__ import annotations

import math
from dataclasses import asdict
from pathlib import Path

import numpy as np

from sensor.contact_detection import PressureContactDetector
from explorer.sensor_evaluation.experiments import REFERENCE_MEAN_NORMAL_ERROR_DEG, EvaluationReport
from explorer.sensor_evaluation.variants import DEFAULT, NOISELESS


def _finite_or_none(value):
    value = float(value)
    return value if math.isfinite(value) else None


def _tilt_key(tilt_deg: float) -> str:
    return f"{tilt_deg:g}"


def to_json_dict(report: EvaluationReport) -> dict:
    """The report as JSON-compatible data (NaN becomes None).

    Keys: ``detection`` (per detector: precision, recall, false_contacts_free_motion, ...),
    ``normal_error_deg`` (RMSE per tilt, default sensor), ``normal_error_mean_deg``,
    ``normal_error_noiseless_mean_deg``, ``speed_realtime_factor`` and supporting figures.
    """
    config = report.config
    detection = {
        name: {
            "precision": _finite_or_none(score.precision),
            "recall": _finite_or_none(score.recall),
            "false_contacts_free_motion": score.false_contacts_free_motion,
            "false_contacts_in_presses": score.false_contacts,
            "contacts": score.contacts,
            "detected": score.detected,
            "median_latency_ms": _finite_or_none(score.median_latency_s * 1e3),
            "p90_latency_ms": _finite_or_none(score.p90_latency_s * 1e3),
        }
        for name, score in report.detection.items()
    }
    normal = report.normal

    def per_tilt(values):
        return {_tilt_key(t): _finite_or_none(v) for t, v in zip(normal.tilts_deg, values)}

    forces = report.press_summary.held_force_n
    result = {
        "detection": detection,
        "normal_error_deg": per_tilt(normal.rmse_deg[DEFAULT]) if normal else None,
        "normal_error_mean_deg": _finite_or_none(normal.mean_deg(DEFAULT)) if normal else None,
        "normal_error_noiseless_mean_deg": _finite_or_none(normal.mean_deg(NOISELESS)) if normal else None,
        "speed_realtime_factor": _finite_or_none(report.speed_realtime_factor),
        "normal_error_by_variant_deg": {name: per_tilt(values) for name, values in normal.rmse_deg.items()}
        if normal else None,
        "pad_misalignment_rms_deg": per_tilt(normal.body_rmse_deg) if normal else None,
        "normal_error_ci95_deg": {_tilt_key(t): [_finite_or_none(v) for v in ci] for t, ci in
                                  zip(normal.tilts_deg, normal.rmse_ci95_deg[DEFAULT])} if normal else None,
        "normal_error_per_press_deg": {_tilt_key(t): [_finite_or_none(p.errors_deg[DEFAULT]) for p in normal.trials
                                                      if p.tilt_deg == t] for t in normal.tilts_deg}
        if normal else None,
        "normal_unsettled_presses": {name: {_tilt_key(t): int(n) for t, n in zip(normal.tilts_deg, counts)}
                                     for name, counts in normal.unsettled.items()} if normal else None,
        "reference_mean_normal_error_deg": REFERENCE_MEAN_NORMAL_ERROR_DEG,
        "presses": {
            "detection_presses": report.press_summary.presses,
            "guard_stops": report.press_summary.guard_stops,
            "other_link_contacts": report.press_summary.other_link_contacts,
            "held_force_n": {"min": _finite_or_none(forces.min()), "median": _finite_or_none(np.median(forces)),
                             "max": _finite_or_none(forces.max())} if len(forces) else None,
            "free_motion_trials": config.free_motion_trials,
            "normal_presses": len(normal.trials) if normal else 0,
        },
        "robots_benchmark": asdict(report.robots_benchmark) if report.robots_benchmark is not None else None,
        "config": {"seed": config.seed, "robot": config.robot, "profile": config.profile.name,
                   "objects": list(config.objects),
                   "tilt_range_deg": list(config.tilt_range_deg), "force_range_n": list(config.force_range_n),
                   "normal_tilts_deg": list(config.normal_tilts_deg),
                   "normal_presses_per_tilt": config.normal_presses_per_tilt,
                   "normal_force_n": config.normal_force_n,
                   "approach_speed_mps": config.protocol.approach_speed_mps},
        "machine": report.machine,
        "wall_s": report.wall_s,
    }
    return result


def _fmt(value, digits: int = 2) -> str:
    return "n/a" if value is None or not math.isfinite(value) else f"{value:.{digits}f}"


def format_table(report: EvaluationReport) -> str:
    """A human-readable summary of the report."""
    lines = [f"Sensor evaluation ({report.config.robot}, profile {report.config.profile.name}, seed "
             f"{report.config.seed}), {report.wall_s:.0f} s wall "
             f"on {report.machine}", ""]
    summary = report.press_summary
    forces = summary.held_force_n
    lines.append(f"1. Contact detection: {summary.presses} presses ({', '.join(report.config.objects)}), "
                 f"{report.config.free_motion_trials} free-motion trials")
    if len(forces):
        lines.append(f"   held force {forces.min():.2f} / {np.median(forces):.2f} / {forces.max():.2f} N "
                     f"(min / median / max); guarded approach stopped by the pressure detector in "
                     f"{summary.guard_stops}/{summary.presses}; other arm links touching: {summary.other_link_contacts}")
    lines.append(f"   {'detector':<13}{'precision':>10}{'recall':>8}{'detected':>10}{'false (presses)':>17}"
                 f"{'false (free motion)':>21}{'latency median / p90':>23}")
    for name, score in report.detection.items():
        latency = f"{_fmt(score.median_latency_s * 1e3, 0)} / {_fmt(score.p90_latency_s * 1e3, 0)} ms"
        lines.append(f"   {name:<13}{_fmt(score.precision):>10}{_fmt(score.recall):>8}"
                     f"{f'{score.detected}/{score.contacts}':>10}{score.false_contacts:>17}"
                     f"{score.false_contacts_free_motion:>21}{latency:>23}")
    normal = report.normal
    if normal is not None:
        lines += ["", f"2. Normal error on the tilted flat slab (RMSE, degrees; {len(normal.trials)} presses, "
                      f"target {report.config.normal_force_n:g} N)"]
        variants = list(normal.rmse_deg)
        lines.append("   " + f"{'tilt':>6}" + "".join(f"{v:>17}" for v in variants) + f"{'pad misaligned':>17}")
        for i, tilt in enumerate(normal.tilts_deg):
            lines.append("   " + f"{tilt:>6g}" + "".join(f"{_fmt(normal.rmse_deg[v][i]):>17}" for v in variants)
                         + f"{_fmt(normal.body_rmse_deg[i]):>17}")
        lines.append("   " + f"{'mean':>6}" + "".join(f"{_fmt(normal.mean_deg(v)):>17}" for v in variants)
                     + f"{_fmt(float(np.mean(normal.body_rmse_deg))):>17}")
        intervals = normal.rmse_ci95_deg.get(DEFAULT)
        if intervals is not None and len(intervals):
            lines.append(f"   {DEFAULT} RMSE 95 % bootstrap interval per tilt: " + ", ".join(
                f"{t:g}: {_fmt(lo, 1)}-{_fmt(hi, 1)}" for t, (lo, hi) in zip(normal.tilts_deg, intervals)))
        unsettled = {v: {f"{t:g} deg": int(n) for t, n in zip(normal.tilts_deg, counts) if n}
                     for v, counts in normal.unsettled.items() if counts.sum()}
        if unsettled:
            lines.append(f"   presses whose orientation never settled in the hold (left out): {unsettled}")
        lines.append(f"   reference hardware sensor: mean {REFERENCE_MEAN_NORMAL_ERROR_DEG} deg over 0-50 deg")
    lines += ["", f"3. Speed: {report.speed_realtime_factor:.1f}x real time (headless, arm pressing objects, "
                  "sensor variants and recording included)"]
    bench = report.robots_benchmark
    if bench is not None:
        lines.append(f"   robots benchmark ({bench.robot}, {bench.object_name}, {bench.simulated_s:g} s simulated): "
                     f"{bench.with_listener_realtime_factor:.1f}x with pad_state() every step, "
                     f"{bench.realtime_factor:.1f}x without")
    return "\n".join(lines)


def write_figures(report: EvaluationReport, out_dir) -> list[Path]:
    """Write the normal-error-vs-tilt figures and sensor traces of the example trials as PNGs."""
    from reconstruction.figures import normal_error_vs_tilt, sensor_traces

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    normal = report.normal
    if normal is not None:
        for variant, filename in ((DEFAULT, "normal_error_vs_tilt.png"),
                                  (NOISELESS, "normal_error_vs_tilt_noiseless.png")):
            pairs = [(t.tilt_deg, t.errors_deg[variant]) for t in normal.trials if math.isfinite(t.errors_deg[variant])]
            if pairs:
                tilts, errors = np.array(pairs).T
                written.append(normal_error_vs_tilt(np.round(tilts, 6), errors, out / filename,
                                                    reference_deg=REFERENCE_MEAN_NORMAL_ERROR_DEG))
    presses = 0
    for recording in report.example_recordings:
        readings = recording.streams[DEFAULT]
        if not readings:
            continue
        events = PressureContactDetector().process(readings)
        if recording.kind == "press":
            presses += 1
            name = f"sensor_traces_press_{presses}_{recording.press.spec.object_name}.png"
        else:
            name = "sensor_traces_free_motion.png"
        written.append(sensor_traces(readings, events, out / name))
    return [Path(p) for p in written]
