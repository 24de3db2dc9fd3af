"""A whole sweep: plan, skip finished runs, execute the rest, then table, summary and figures."""
from __future__ import annotations

import json
import shutil
from dataclasses import dataclass, field
from pathlib import Path

from explorer.sweep.execution import RunJob, RunOutcome, run_in_pool, run_on_ray
from explorer.sweep.figures import error_figures
from explorer.sweep.plan import (SweepConfig, is_complete, object_label, plan_runs,
                                 prepare_sweep_dir, read_metrics, run_dir)
from explorer.sweep.results import read_csv, summarise, table_row, write_csv, write_markdown

NOT_RUN = "not run: the sweep stopped before this run finished"


@dataclass
class SweepReport:
    """What a call of :func:`run_sweep` did.

    Attributes
    ----------
    executed : list of str
        Names of the runs executed by this call (finished or failed), in completion order.
    skipped : list of str
        Runs already finished before this call.
    failures : list of RunOutcome
        Runs of this call that raised.
    rows : list of dict
        The table, as read back from ``sweep.csv``.
    figures : list of Path
    """

    out_dir: Path
    executed: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    failures: list[RunOutcome] = field(default_factory=list)
    rows: list[dict] = field(default_factory=list)
    figures: list[Path] = field(default_factory=list)

    @property
    def csv_path(self) -> Path:
        return self.out_dir / "sweep.csv"

    @property
    def markdown_path(self) -> Path:
        return self.out_dir / "sweep.md"

    @property
    def failures_path(self) -> Path:
        return self.out_dir / "failures.json"


def run_sweep(config: SweepConfig, out_dir, workers: int = 2, ray_address: str | None = None,
              show_progress: bool = True) -> SweepReport:
    """Run every unfinished run of ``config`` and write the sweep's outputs to ``out_dir``.

    Writes ``runs/<name>/`` (one :func:`explorer.run.explore` output each), ``sweep.csv``,
    ``sweep.md``, ``failures.json`` (run, error, traceback of each run that raised) and
    ``figures/<object>_{position,normal}_error.png``. The table is written also when the sweep is
    interrupted, with the unfinished runs marked. A run directory without a completed
    ``metrics.json`` is deleted and its run starts over. One sweep per directory at a time.

    Parameters
    ----------
    workers : int
        Runs at a time (process-pool size, or the CPUs of a local Ray instance).
    ray_address : str, optional
        Run on Ray instead of a process pool: ``"local"`` or a cluster address.
    """
    if workers < 1:
        raise ValueError(f"workers must be at least 1, got {workers}")
    out_dir = Path(out_dir)
    prepare_sweep_dir(out_dir, config)
    plan = plan_runs(config)
    report = SweepReport(out_dir)
    jobs = []
    for run in plan:
        directory = run_dir(out_dir, run)
        if is_complete(directory):
            report.skipped.append(run.name)
            continue
        if directory.exists():
            # What an interrupted or failed run left is superseded: the run starts over.
            shutil.rmtree(directory)
        jobs.append(RunJob(run.name, run.settings(config), directory))
    bar = _progress_bar(len(plan), len(report.skipped), show_progress)

    def on_done(outcome: RunOutcome) -> None:
        report.executed.append(outcome.name)
        if not outcome.ok:
            report.failures.append(outcome)
        bar.update(1)
        bar.set_postfix_str(f"{len(report.failures)} failed, last {outcome.name}")

    try:
        if ray_address is None:
            run_in_pool(jobs, workers, on_done)
        else:
            run_on_ray(jobs, ray_address, workers, on_done)
    finally:
        bar.close()
        _write_outputs(config, plan, report)
    return report


def _write_outputs(config: SweepConfig, plan, report: SweepReport) -> None:
    errors = {f.name: f.error for f in report.failures}
    rows, finished = [], []
    for run in plan:
        metrics = read_metrics(run_dir(report.out_dir, run))
        error = errors.get(run.name)
        if error is None and not is_complete(run_dir(report.out_dir, run)):
            error = NOT_RUN
        rows.append(table_row(run, object_label(run.object), metrics, error))
        if error is None:
            finished.append((object_label(run.object), run.strategy, run.use_normals,
                             metrics.get("error_curve", [])))
    write_csv(rows, report.csv_path)
    report.rows = read_csv(report.csv_path)
    description = (f"{len(plan)} runs: objects {', '.join(object_label(o) for o in config.objects)}; "
                   f"strategies {', '.join(config.strategies)}; seeds {', '.join(map(str, config.seeds))}; "
                   f"{config.touches} touches, robot {config.robot}.")
    write_markdown(summarise(report.rows), report.rows, report.markdown_path, description)
    report.failures_path.write_text(json.dumps(
        [dict(run=f.name, error=f.error, traceback=f.traceback) for f in report.failures], indent=2))
    report.figures = error_figures(finished, report.out_dir / "figures")


def _progress_bar(total: int, done: int, show: bool):
    from tqdm import tqdm

    return tqdm(total=total, initial=done, unit="run", desc="sweep", disable=not show)
