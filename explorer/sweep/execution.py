"""Running sweep runs in separate processes: a local process pool or Ray tasks.

Each run is one call of :func:`execute_run` in a fresh-started worker (spawn: PyBullet and torch
are not fork-safe). A run that raises becomes a failed :class:`RunOutcome`; it never stops the
others. Both executors report each outcome through ``on_done`` as it arrives (for a progress bar).
"""
from __future__ import annotations

import multiprocessing
import time
import traceback
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

from explorer.run import RunSettings


@dataclass(frozen=True)
class RunJob:
    """One run to execute: its name, settings and output directory."""

    name: str
    settings: RunSettings
    out_dir: Path


@dataclass(frozen=True)
class RunOutcome:
    """How a run ended.

    Attributes
    ----------
    name : str
    error : str or None
        ``"<ExceptionType>: <message>"`` of a failed run, None for a finished one.
    traceback : str
        The worker's traceback of a failed run, empty otherwise.
    wall_s : float
        Seconds the worker spent on the run (0 where the worker died).
    """

    name: str
    error: str | None = None
    traceback: str = ""
    wall_s: float = 0.0

    @property
    def ok(self) -> bool:
        return self.error is None


def execute_run(job: RunJob) -> RunOutcome:
    """Run one exploration in this process (the worker function of both executors)."""
    import torch

    from explorer.run import explore

    # Small tensors: extra intra-op threads only add synchronisation, and with one run per core
    # they oversubscribe the machine (see scripts/explore.py).
    torch.set_num_threads(1)
    start = time.perf_counter()
    try:
        explore(job.settings, job.out_dir)
    except Exception as exc:  # recorded in the sweep's table; the sweep goes on
        return RunOutcome(job.name, f"{type(exc).__name__}: {exc}", traceback.format_exc(),
                          time.perf_counter() - start)
    return RunOutcome(job.name, wall_s=time.perf_counter() - start)


OnDone = Callable[[RunOutcome], None]


def run_in_pool(jobs: Sequence[RunJob], workers: int, on_done: OnDone,
                start_method: str = "spawn") -> list[RunOutcome]:
    """Execute ``jobs`` on a local pool of ``workers`` processes; outcomes in completion order.

    A worker that dies (a crash in native code) fails the runs it and the broken pool could not
    finish; they are recorded like any other failure.
    """
    if workers < 1:
        raise ValueError(f"workers must be at least 1, got {workers}")
    if start_method not in ("spawn", "forkserver"):
        raise ValueError(f"start_method must be 'spawn' or 'forkserver' (PyBullet and torch are not "
                         f"fork-safe), got {start_method!r}")
    outcomes: list[RunOutcome] = []
    if not jobs:
        return outcomes
    context = multiprocessing.get_context(start_method)
    with ProcessPoolExecutor(max_workers=min(workers, len(jobs)), mp_context=context) as pool:
        futures = {pool.submit(execute_run, job): job for job in jobs}
        pending = set(futures)
        try:
            while pending:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for future in done:
                    try:
                        outcome = future.result()
                    except BrokenProcessPool as exc:
                        outcome = RunOutcome(futures[future].name, f"worker process died: {exc}")
                    outcomes.append(outcome)
                    on_done(outcome)
        except BaseException:  # Ctrl-C: stop now, not after the runs already queued to workers
            _stop_workers(pool)
            raise
    return outcomes


def _stop_workers(pool: ProcessPoolExecutor) -> None:
    terminate = getattr(pool, "terminate_workers", None)  # Python >= 3.14
    if terminate is not None:
        terminate()
        return
    # Before 3.14 the pool has no public way; a worker would otherwise go on with the runs
    # already handed to it (an unfinished run is redone from scratch on restart anyway).
    processes = list((getattr(pool, "_processes", None) or {}).values())
    for process in processes:
        process.terminate()
    # The pool's manager thread sees its workers die and reaps them. Waiting for it means no
    # thread is still half-way through reaping a worker when this returns (a worker reaped by
    # the other thread would otherwise look alive to multiprocessing.active_children()).
    pool.shutdown(wait=True, cancel_futures=True)
    for process in processes:
        process.join(timeout=10)
        if process.is_alive():
            process.kill()
            process.join()


def run_on_ray(jobs: Sequence[RunJob], address: str, workers: int, on_done: OnDone) -> list[RunOutcome]:
    """Execute ``jobs`` as Ray tasks (one CPU each); outcomes in completion order.

    Parameters
    ----------
    address : str
        ``"local"`` starts a private Ray instance with ``workers`` CPUs (shut down afterwards);
        anything else is passed to ``ray.init(address=...)`` (``"auto"``, ``"ray://host:10001"``).
        On a cluster the output directory must be on a file system every node shares.
    """
    ray = _import_ray()
    if workers < 1:
        raise ValueError(f"workers must be at least 1, got {workers}")
    if not address:
        raise ValueError("a Ray address is required ('local', 'auto' or a cluster address)")
    outcomes: list[RunOutcome] = []
    if not jobs:
        return outcomes
    started_here = not ray.is_initialized()
    if started_here:
        if address == "local":
            ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
        else:
            ray.init(address=address, log_to_driver=False)
    try:
        remote_run = ray.remote(num_cpus=1, max_retries=0)(execute_run)
        refs = {remote_run.remote(job): job for job in jobs}
        pending = list(refs)
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            for ref in done:
                try:
                    outcome = ray.get(ref)
                except ray.exceptions.RayError as exc:  # the worker died, or the task was lost
                    outcome = RunOutcome(refs[ref].name, f"Ray task failed: {type(exc).__name__}: {exc}")
                outcomes.append(outcome)
                on_done(outcome)
    finally:
        if started_here:
            ray.shutdown()
    return outcomes


def _import_ray():
    try:
        import ray
    except ImportError as exc:
        raise ImportError("running a sweep on Ray needs the optional 'ray' package: "
                          "pip install 'tactile-explore[ray]' (or pip install ray)") from exc
    return ray
