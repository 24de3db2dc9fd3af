"""Benchmark sweeps: objects x strategies x normals x seeds, each run in its own process.

Public API: :class:`SweepConfig`, :func:`run_sweep` (-> :class:`SweepReport`), and the pieces it
is made of: :func:`plan_runs`, :func:`is_complete`, :func:`run_in_pool`, :func:`run_on_ray`,
:func:`read_csv`, :func:`summarise`, :func:`touches_to_reach`. Command line: ``tactile-sweep``.
"""
from explorer.sweep.execution import RunJob, RunOutcome, execute_run, run_in_pool, run_on_ray
from explorer.sweep.plan import SweepConfig, SweepRun, is_complete, plan_runs, run_dir
from explorer.sweep.results import (COLUMNS, SECOND_TARGET_RMSE_MM, TARGET_RMSE_MM, SummaryRow, read_csv,
                                    summarise, touches_to_reach)
from explorer.sweep.runner import SweepReport, run_sweep

__all__ = [
    "COLUMNS", "RunJob", "SECOND_TARGET_RMSE_MM", "RunOutcome", "SummaryRow", "SweepConfig", "SweepReport", "SweepRun",
    "TARGET_RMSE_MM", "execute_run", "is_complete", "plan_runs", "read_csv", "run_dir",
    "run_in_pool", "run_on_ray", "run_sweep", "summarise", "touches_to_reach",
]
