"""A sweep's results as one table (``sweep.csv``) and its Markdown summary (``sweep.md``).

Rows come from each run's ``metrics.json``; a failed run keeps its grid cell and error message and
leaves the numbers empty. The summary groups rows by object x strategy x normals and gives mean and
(population) standard deviation over the seeds that finished.
"""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from explorer.evaluation import STANDARD_METRICS

#: Error level of the ``touches_to_3mm`` column, millimetres.
TARGET_RMSE_MM = 3.0
#: Error level of the ``touches_to_2mm`` column, millimetres.
SECOND_TARGET_RMSE_MM = 2.0

#: ``metrics.json``'s ``recess`` figures (:class:`reconstruction.metrics.RecessError`) as sweep columns.
RECESS_COLUMNS = ("recess_fraction", "recess_rmse_mm", "open_rmse_mm", "recess_coverage")
COLUMNS = ("object", "strategy", "normals", "seed", "touches", "contacts", "position_rmse_mm",
           "normal_rmse_deg", *STANDARD_METRICS, "coverage", "extra_handles", *RECESS_COLUMNS, "wall_time_s",
           "touches_to_3mm", "touches_to_2mm",
           "completed", "error", "run")
NUMERIC = ("touches", "contacts", "position_rmse_mm", "normal_rmse_deg", *STANDARD_METRICS, "coverage",
           "extra_handles", *RECESS_COLUMNS, "wall_time_s", "touches_to_3mm", "touches_to_2mm")


def touches_to_reach(error_curve: Sequence[dict], target_mm: float = TARGET_RMSE_MM) -> int | None:
    """First touch count of a run's ``error_curve`` whose position RMSE is at or below ``target_mm``."""
    for point in sorted(error_curve, key=lambda p: p["touches"]):
        if point["position_rmse_mm"] <= target_mm:
            return int(point["touches"])
    return None


def table_row(run, label: str, metrics: dict | None, error: str | None) -> dict:
    """One ``sweep.csv`` row (values as Python scalars, None for empty).

    Parameters
    ----------
    run : explorer.sweep.plan.SweepRun
    label : str
        The object's name in the table (a mesh file's stem).
    metrics : dict or None
        The run's ``metrics.json``; only used when the run completed.
    error : str or None
        Why the run failed; None for a completed run.
    """
    row = dict(object=label, strategy=run.strategy, normals=run.use_normals, seed=run.seed,
               completed=error is None, error=error, run=run.name)
    for key in NUMERIC:
        row[key] = None
    if error is None:
        if metrics is None:
            raise ValueError(f"run {run.name} has no metrics.json but no error either")
        for key in NUMERIC[:-2]:
            row[key] = (metrics.get("recess") or {}).get(key) if key in RECESS_COLUMNS else metrics.get(key)
        row["touches_to_3mm"] = touches_to_reach(metrics.get("error_curve", []))
        row["touches_to_2mm"] = touches_to_reach(metrics.get("error_curve", []), SECOND_TARGET_RMSE_MM)
    return row


def write_csv(rows: Sequence[dict], path: Path) -> Path:
    """Write the table; floats at full precision, empty cells for None."""
    with open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=COLUMNS)
        writer.writeheader()
        for row in rows:
            writer.writerow({k: _cell(row[k]) for k in COLUMNS})
    return Path(path)


def read_csv(path: Path) -> list[dict]:
    """``sweep.csv`` back as rows with numbers, booleans and None (the inverse of :func:`write_csv`)."""
    with open(path, newline="") as handle:
        rows = list(csv.DictReader(handle))
    parsed = []
    for row in rows:
        out = dict(row)
        out["normals"] = row["normals"] == "true"
        out["completed"] = row["completed"] == "true"
        out["seed"] = int(row["seed"])
        out["error"] = row["error"] or None
        for key in NUMERIC:  # a table written before a column existed reads it as empty
            out[key] = None if row.get(key, "") in ("", None) else float(row[key])
        parsed.append(out)
    return parsed


@dataclass(frozen=True)
class SummaryRow:
    """One object x strategy x normals group of the summary; statistics over finished seeds.

    Errors are mean and population standard deviation (NaN where no seed finished);
    ``touches_to_target_mean`` averages the seeds that reached the target (NaN where none did);
    ``standard`` holds the mean of each of ``STANDARD_METRICS`` (NaN where no seed has it);
    ``reached_2mm`` and ``touches_to_2mm_mean`` are the same for ``SECOND_TARGET_RMSE_MM``;
    ``extra_handles_mean``: handles the reconstruction has beyond the truth's (``metrics.json``'s
    ``extra_handles``: holes through thin walls), NaN for runs from before it was recorded.
    """

    object: str
    strategy: str
    normals: bool
    runs: int
    completed: int
    position_rmse_mm_mean: float
    position_rmse_mm_std: float
    normal_rmse_deg_mean: float
    normal_rmse_deg_std: float
    coverage_mean: float
    reached_target: int
    touches_to_target_mean: float
    standard: dict
    reached_2mm: int = 0
    touches_to_2mm_mean: float = math.nan
    extra_handles_mean: float = math.nan


def summarise(rows: Sequence[dict]) -> list[SummaryRow]:
    """Group ``rows`` (as from :func:`read_csv`) by object, strategy and normals, in table order."""
    groups: dict[tuple, list[dict]] = {}
    for row in rows:
        groups.setdefault((row["object"], row["strategy"], row["normals"]), []).append(row)
    summary = []
    for (obj, strategy, normals), members in groups.items():
        done = [r for r in members if r["completed"]]
        position = _values(done, "position_rmse_mm")
        angle = _values(done, "normal_rmse_deg")
        reached = _values(done, "touches_to_3mm")
        reached_2mm = _values(done, "touches_to_2mm")
        summary.append(SummaryRow(
            obj, strategy, normals, len(members), len(done), _mean(position), _std(position),
            _mean(angle), _std(angle), _mean(_values(done, "coverage")), len(reached), _mean(reached),
            {key: _mean(_values(done, key)) for key in STANDARD_METRICS}, len(reached_2mm), _mean(reached_2mm),
            _mean(_values(done, "extra_handles"))))
    return summary


def write_markdown(summary: Sequence[SummaryRow], rows: Sequence[dict], path: Path,
                   description: str = "") -> Path:
    """The summary table, then the failed runs with their errors."""
    lines = ["# Sweep summary", ""]
    if description:
        lines += [description, ""]
    lines += [
        f"Mean +- population std over the seeds that finished. Touches to {TARGET_RMSE_MM:g} / "
        f"{SECOND_TARGET_RMSE_MM:g} mm: first evaluated touch count with a position RMSE at or below it, "
        "mean over the seeds whose error curve reached it (how many of them in brackets).",
        "",
        "Chamfer L1 / L2 (mm), F-score at 1 / 2 / 5 mm and normal consistency: means over the same "
        "seeds, defined in `reconstruction.metrics.ShapeMetrics`. Extra handles: the reconstruction's "
        "genus minus the truth's (holes through thin walls; `reconstruction.topology`), mean over the seeds.",
        "",
        "| object | strategy | normals | finished | position RMSE (mm) | normal RMSE (deg) | Chamfer L1 (mm) "
        "| Chamfer L2 (mm) | F@1mm | F@2mm | F@5mm | normal consistency | coverage | extra handles "
        f"| touches to {TARGET_RMSE_MM:g} mm | touches to {SECOND_TARGET_RMSE_MM:g} mm |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for s in summary:
        lines.append(
            f"| {s.object} | {s.strategy} | {'yes' if s.normals else 'no'} | {s.completed}/{s.runs} "
            f"| {_pm(s.position_rmse_mm_mean, s.position_rmse_mm_std)} "
            f"| {_pm(s.normal_rmse_deg_mean, s.normal_rmse_deg_std, 1)} "
            f"| {_fmt(s.standard['chamfer_l1_mm'])} | {_fmt(s.standard['chamfer_l2_mm'])} "
            f"| {_fmt(s.standard['fscore_1mm'], 3)} | {_fmt(s.standard['fscore_2mm'], 3)} "
            f"| {_fmt(s.standard['fscore_5mm'], 3)} | {_fmt(s.standard['normal_consistency'], 3)} "
            f"| {_fmt(s.coverage_mean, 3)} | {_fmt(s.extra_handles_mean, 1)} "
            f"| {_fmt(s.touches_to_target_mean, 1)} ({s.reached_target}/{s.completed}) "
            f"| {_fmt(s.touches_to_2mm_mean, 1)} ({s.reached_2mm}/{s.completed}) |")
    failed = [r for r in rows if not r["completed"]]
    if failed:
        lines += ["", f"## Failed runs ({len(failed)})", "", "Rerun the sweep with the same arguments "
                  "to retry them (finished runs are kept).", ""]
        lines += [f"- `{r['run']}`: {_one_line(r['error'])}" for r in failed]
    Path(path).write_text("\n".join(lines) + "\n")
    return Path(path)


def _values(rows: Sequence[dict], key: str) -> np.ndarray:
    return np.array([r.get(key) for r in rows if r.get(key) is not None], float)


def _mean(values: np.ndarray) -> float:
    return float(values.mean()) if len(values) else math.nan


def _std(values: np.ndarray) -> float:
    return float(values.std()) if len(values) else math.nan


def _fmt(value: float, digits: int = 2) -> str:
    return "-" if math.isnan(value) else f"{value:.{digits}f}"


def _pm(mean: float, std: float, digits: int = 2) -> str:
    return "-" if math.isnan(mean) else f"{mean:.{digits}f} +- {std:.{digits}f}"


def _one_line(text: str | None) -> str:
    return " ".join((text or "").split())


def _cell(value) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    return str(value)
