"""The reference work's accuracy table, replicated like for like, under every simulation profile.

The reference reports position RMSE with and without normals for two kinds of experiment: box,
sphere, cylinder and banana in simulation, and ground coffee, a Cheez-It box, a flat surface (on
ARMAR-6) and a bowl (on ARMAR-III) on real robots. :data:`ROWS` maps each to a registry object
and robot; each row runs under every profile asked for (so the cost of each error source can be
read off) and, for ``hardware-like``, also with the arm calibrated from ball touches. The *main*
column of a row is its own kind's: the default profile for simulation rows, ``hardware-like``
calibrated (as a lab would run it) for real-robot rows.

Runs are ordinary sweep runs (:mod:`explorer.sweep`: one directory per group of robot, profile
and calibration, resumable, run on one process pool). *With normals* is the run's own
reconstruction. *Without normals* is, as the reference ran it, a second exploration of the main
column driven and scored by the classic GPIS (one inside and 14 outside samples instead of normals;
a ``nonormals`` sweep run). Every cell also gets the classic GPIS refitted on the with-normals
run's own contacts (:func:`classic_refit`): the value of the normals alone, without the
exploration they steered.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from explorer.sweep.execution import RunJob
from explorer.sweep.plan import SweepConfig, is_complete, plan_runs, prepare_sweep_dir, read_metrics, run_dir

CALIBRATED = "hardware-like, calibrated"
"""Column name of the hardware-like profile with the arm calibrated from ball touches."""


@dataclass(frozen=True)
class ReferenceRow:
    """One row of the reference table.

    Attributes
    ----------
    label : str
        The reference's object.
    object : str
        Our registry object standing for it.
    kind : {'simulation', 'real robot'}
    robot : str
        The robot the reference used (ours: its registry model).
    reference_with_mm, reference_without_mm : float or None
        The reference's position RMSE with and without normals, mm (None: not known here).
    """

    label: str
    object: str
    kind: str
    robot: str
    reference_with_mm: float | None
    reference_without_mm: float | None

    @property
    def main_column(self) -> str:
        return "datasheet-noise" if self.kind == "simulation" else CALIBRATED

    def main_column_among(self, cols) -> str:
        """The main column, or uncalibrated ``hardware-like`` where the calibration is left out."""
        return self.main_column if self.main_column in cols else "hardware-like"


ROWS: tuple[ReferenceRow, ...] = (
    ReferenceRow("box", "box", "simulation", "armar3", 2.7, 5.2),
    ReferenceRow("sphere", "sphere", "simulation", "armar3", 0.5, 1.9),
    ReferenceRow("cylinder", "cylinder", "simulation", "armar3", 3.2, 6.0),
    ReferenceRow("banana", "banana", "simulation", "armar3", 1.8, 5.9),
    ReferenceRow("ground coffee", "coffee_can", "real robot", "armar6", 3.5, None),
    ReferenceRow("Cheez-It", "cereal_box", "real robot", "armar6", 3.5, None),
    ReferenceRow("flat surface", "flat", "real robot", "armar6", 2.8, None),
    ReferenceRow("bowl", "bowl", "real robot", "armar3", 4.7, None),
)
PROFILE_COLUMNS = ("ideal", "datasheet-noise", "hardware-like")


def rows_named(names) -> tuple[ReferenceRow, ...]:
    """The rows whose object or label is in ``names`` (table order); ValueError naming unknown ones."""
    names = list(names)
    known = {r.object for r in ROWS} | {r.label for r in ROWS}
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ValueError(f"unknown rows {unknown}; use objects from {', '.join(r.object for r in ROWS)}")
    return tuple(r for r in ROWS if r.object in names or r.label in names)


def columns(profiles, calibrated: bool) -> tuple[str, ...]:
    """Column names: the profiles asked for, then the calibrated hardware-like one."""
    extra = (CALIBRATED,) if calibrated and "hardware-like" in profiles else ()
    return tuple(profiles) + extra


def group_dir(out_dir: Path, robot: str, column: str) -> Path:
    return Path(out_dir) / "sweeps" / f"{robot}-{column.replace(', ', '-')}"


def plan_jobs(out_dir: Path, rows, cols, touches: int, seed: int, calibrations: dict, eval_every: int,
              mesh_resolution: int, explore_without_normals: bool = True) -> tuple[list[RunJob], dict]:
    """The runs still to do (main columns first) and where every cell's runs live.

    ``calibrations`` maps a robot to its ``joint_calibration.json`` (for the calibrated column).
    ``explore_without_normals``: also explore each row's main column without normals.
    Returns (jobs, cells) with cells[(row.object, column, use_normals)] = run directory.
    """
    cells, order = {}, []
    for column in cols:
        for robot in sorted({r.robot for r in rows}):
            members = [r for r in rows if r.robot == robot]
            calibration = None
            if column == CALIBRATED:
                if robot not in calibrations:
                    continue
                calibration = str(calibrations[robot])
            config = SweepConfig(objects=tuple(r.object for r in members), strategies=("variance",), seeds=(seed,),
                                 normals=(True, False), touches=touches, robot=robot, eval_every=eval_every,
                                 mesh_resolution=mesh_resolution,
                                 profile="hardware-like" if column == CALIBRATED else column, calibration=calibration)
            directory = group_dir(out_dir, robot, column)
            prepare_sweep_dir(directory, config)
            for run in plan_runs(config):
                row = next(r for r in members if r.object == run.object)
                main = column == row.main_column_among(cols)
                if not run.use_normals and not (explore_without_normals and main):
                    continue
                path = run_dir(directory, run)
                cells[(row.object, column, run.use_normals)] = path
                if not is_complete(path):
                    order.append((_priority(main, column, run.use_normals),
                                  RunJob(f"{robot}-{column}-{run.name}", run.settings(config), path)))
    jobs = [job for _, job in sorted(order, key=lambda item: item[0])]
    return jobs, cells


def clear_unfinished(jobs) -> None:
    """Delete what unfinished runs left: each starts over, as in a sweep."""
    import shutil

    for job in jobs:
        if job.out_dir.exists():
            shutil.rmtree(job.out_dir)


def _priority(main: bool, column: str, use_normals: bool) -> int:
    """Run order: each row's main column with normals, then without, then hardware-like
    uncalibrated (the calibration's before), the default profile, the rest."""
    if main:
        return 0 if use_normals else 1
    return {"hardware-like": 2, "datasheet-noise": 3}.get(column, 4)


def read_contacts(run_directory: Path) -> tuple[np.ndarray, np.ndarray]:
    """(points (n, 3), outward normals (n, 3)) of a run's ``contacts.csv``, object frame, metres."""
    import csv

    with open(Path(run_directory) / "contacts.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    points = np.array([[float(r[k]) for k in ("x", "y", "z")] for r in rows]).reshape(-1, 3)
    normals = np.array([[float(r[k]) for k in ("nx", "ny", "nz")] for r in rows]).reshape(-1, 3)
    return points, normals


def classic_refit(run_directory: Path, resolution: int) -> dict:
    """The reference's baseline from a run's contacts: GPIS without normals (one inside and 14
    outside samples), meshed at ``resolution`` as the loop meshes its runs (its
    ``reconstruction_refine_steps``: the same contacts, the same vertices) and scored against the
    truth; cached in the run's ``classic_gpis.json``."""
    import objects
    from explorer.evaluation import jsonable, reconstruction_errors
    from explorer.loop import LoopConfig
    from explorer.outputs import write_json
    from explorer.rig import object_prior
    from reconstruction.gpis import GPIS

    cache = Path(run_directory) / "classic_gpis.json"
    if cache.exists():
        return json.loads(cache.read_text())
    metrics = read_metrics(run_directory) or {}
    truth = objects.load(metrics.get("object")).mesh
    points, normals = read_contacts(run_directory)
    result: dict = dict(contacts=int(len(points)), resolution=resolution)
    try:
        gpis = GPIS(bounds=object_prior(truth).bounds(), use_normals=False).fit(points, normals)
        mesh = gpis.mesh(resolution=resolution, refine_steps=LoopConfig.reconstruction_refine_steps)
        result.update(reconstruction_errors(mesh, truth, points, normals))
    except ValueError as error:  # too few contacts, no zero level set
        result["error"] = str(error)
    result = jsonable(result)
    write_json(cache, result)
    return result


def collect(cells: dict, rows, cols, resolution: int) -> list[dict]:
    """One record per cell: the run's figures with normals, the exploration's without normals
    (main columns; None where it is not run or not finished) and the classic refit of the run's
    own contacts."""
    records = []
    for row in rows:
        for column in cols:
            path = cells.get((row.object, column, True))
            record = dict(row=row.label, object=row.object, kind=row.kind, robot=row.robot, column=column,
                          main=column == row.main_column_among(cols), reference_with_mm=row.reference_with_mm,
                          reference_without_mm=row.reference_without_mm, run=None if path is None else str(path))
            metrics = None if path is None else read_metrics(path)
            if metrics is None or not metrics.get("completed"):
                record["missing"] = "not run" if path is None else "not finished"
                records.append(record)
                continue
            classic = classic_refit(path, resolution)
            without_path = cells.get((row.object, column, False))
            without = None if without_path is None else read_metrics(without_path)
            if without is not None and not without.get("completed"):
                without = None
            record.update(touches=metrics.get("touches"), contacts=metrics.get("contacts"),
                          with_normals_mm=metrics.get("position_rmse_mm"),
                          with_normals_normal_deg=metrics.get("normal_rmse_deg"),
                          without_normals_mm=None if without is None else without.get("position_rmse_mm"),
                          without_normals_contacts=None if without is None else without.get("contacts"),
                          without_normals_run=None if without_path is None else str(without_path),
                          same_contacts_without_normals_mm=classic.get("position_rmse_mm"),
                          chamfer_l1_mm=metrics.get("chamfer_l1_mm"), fscore_2mm=metrics.get("fscore_2mm"),
                          contact_position_error_rms_mm=metrics.get("contact_position_error_rms_mm"),
                          contact_normal_error_mean_deg=metrics.get("contact_normal_error_mean_deg"),
                          wall_time_s=metrics.get("wall_time_s"))
            records.append(record)
    return records


def _mm(value) -> str:
    return "-" if value is None or not math.isfinite(float(value)) else f"{float(value):.2f}"


def format_markdown(records: list[dict], cols, description: str) -> str:
    """Two tables: the like-for-like rows (main column; without normals = explored without them)
    and every row under every column (without normals = the classic refit of the same contacts)."""
    lines = [description, "",
             "| row | kind | robot | object | column | touches | contacts with / without normals "
             "| with normals (mm) | without normals, explored (mm) | classic refit of the same contacts (mm) "
             "| reference with / without (mm) | with <= reference | with < without |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in (r for r in records if r["main"]):
        if "missing" in r:
            lines.append(f"| {r['row']} | {r['kind']} | {r['robot']} | {r['object']} | {r['column']} | - | - | "
                         f"{r['missing']} | - | - | {_mm(r['reference_with_mm'])} / {_mm(r['reference_without_mm'])} "
                         "| - | - |")
            continue
        meets = "-" if r["reference_with_mm"] is None or r["with_normals_mm"] is None else \
            ("yes" if r["with_normals_mm"] <= r["reference_with_mm"] else "no")
        better = "-" if r.get("without_normals_mm") is None or r["with_normals_mm"] is None else \
            ("yes" if r["with_normals_mm"] < r["without_normals_mm"] else "no")
        without_contacts = "-" if r.get("without_normals_contacts") is None else r["without_normals_contacts"]
        lines.append(f"| {r['row']} | {r['kind']} | {r['robot']} | {r['object']} | {r['column']} | {r['touches']} | "
                     f"{r['contacts']} / {without_contacts} | {_mm(r['with_normals_mm'])} | "
                     f"{_mm(r.get('without_normals_mm'))} | {_mm(r['same_contacts_without_normals_mm'])} | "
                     f"{_mm(r['reference_with_mm'])} / {_mm(r['reference_without_mm'])} | {meets} | {better} |")
    lines += ["", "Every row under every column (position RMSE, mm: with normals / the classic refit of the "
              "same contacts):", "",
              "| row | robot | " + " | ".join(cols) + " |", "|---|---|" + "---|" * len(cols)]
    for label in dict.fromkeys(r["row"] for r in records):
        cells = {r["column"]: r for r in records if r["row"] == label}
        first = next(iter(cells.values()))
        values = []
        for column in cols:
            r = cells.get(column)
            if r is None or "missing" in r:
                values.append(r["missing"] if r else "not run")
            else:
                values.append(f"{_mm(r['with_normals_mm'])} / {_mm(r['same_contacts_without_normals_mm'])}")
        lines.append(f"| {label} | {first['robot']} | " + " | ".join(values) + " |")
    return "\n".join(lines) + "\n"
