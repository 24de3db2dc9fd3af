"""A whole simulated exploration run: scene, loop, outputs. The main job of the project.

Writes to the output directory, as the run goes:

* ``session/``          everything the run saw (sensor stream, joint states, contacts, events);
* ``contacts.csv``      one row per contact, object frame, metres, outward normals;

and at the end (also after an interruption, from what was recorded):

* ``reconstruction.ply`` the GPIS mean surface, object frame;
* ``metrics.json``       errors against the ground truth, touches, misses, coverage, times;
* ``reconstruction_error.png``, ``error_vs_touches.png``, ``potential_slice.png``.
"""
from __future__ import annotations

import json
import platform
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from explorer.coverage import reachable_fraction
from explorer.evaluation import jsonable, reconstruction_errors
from explorer.loop import LOOP_SETTLING, ExplorationLoop, LoopConfig, TouchRecord
from explorer.planner import ApproachPlanner, PlannerConfig
from explorer.recording import RunRecorder
from explorer.simulation import build_scene
from explorer.strategies import make_strategy
from explorer.touch import ObjectPrior
from reconstruction.gpis import GPIS
from reconstruction.metrics import surface_error
from sensor.contact_detection import PressureDetectorConfig
from sensor.normal_estimation import SettlingConfig

#: The prior box: the object's bounding box grown by this fraction of its size plus a centimetre
#: (a rough location and size; an over-estimate is safe).
PRIOR_GROWTH = 0.1
PRIOR_MARGIN_M = 0.01


@dataclass
class RunSettings:
    """Everything that defines a run (saved in the session metadata)."""

    object: str = "banana"
    robot: str = "armar3"
    strategy: str = "variance"
    touches: int = 50
    seed: int = 0
    use_normals: bool = True
    gui: bool = False
    eval_every: int = 5
    mesh_resolution: int = 96
    loop: LoopConfig = field(default_factory=LoopConfig)
    planner: PlannerConfig = field(default_factory=PlannerConfig)


@dataclass
class RunResult:
    records: list[TouchRecord]
    gpis: GPIS
    metrics: dict
    out_dir: Path


def object_prior(mesh) -> ObjectPrior:
    """The rough location and size the loop is given (object frame)."""
    lo, hi = mesh.bounds
    return ObjectPrior(0.5 * (lo + hi), 0.5 * (hi - lo) * (1 + PRIOR_GROWTH) + PRIOR_MARGIN_M)


def explore(settings: RunSettings, out_dir: Path, progress=None) -> RunResult:
    """Run one simulated exploration and write its outputs to ``out_dir``."""
    from robots.ik import PadIK

    out_dir = Path(out_dir)
    wall0 = time.perf_counter()
    loop_settings = LoopConfig(**{**asdict(settings.loop), "touches": settings.touches})
    with build_scene(settings.object, settings.robot, seed=settings.seed, gui=settings.gui) as scene:
        truth = scene.object_model.mesh
        prior = object_prior(truth)
        planner = ApproachPlanner(scene.kinematics, PadIK(scene.kinematics), scene.stand, prior,
                                  settings.planner)
        gpis = GPIS(bounds=prior.bounds(), use_normals=settings.use_normals)
        configuration = dict(asdict(settings), detector=asdict(PressureDetectorConfig()),
                             settling=asdict(SettlingConfig(**LOOP_SETTLING)),
                             stand_centre_m=scene.stand.centre_m,
                             prior=dict(centre_m=prior.centre_m, half_extent_m=prior.half_extent_m))
        metadata = dict(robot=settings.robot, sensor="simulated BNO055 + BMP280 under polyurethane",
                        object=settings.object, seed=settings.seed,
                        configuration=jsonable(configuration), backend="simulation")
        recorder = RunRecorder(out_dir, metadata)
        loop = ExplorationLoop(scene.arm, scene.sensor, scene.kinematics, planner, scene.stand,
                               make_strategy(settings.strategy, settings.seed), prior, gpis,
                               loop_settings, recorder)
        curve: list[tuple[int, float, float]] = []
        eval_s = [0.0]

        def after_touch(record: TouchRecord) -> None:
            if progress is not None:
                progress(record)
            n = len(loop.records)
            if settings.eval_every and n % settings.eval_every == 0 and gpis.n_contacts >= 4:
                t0 = time.perf_counter()
                try:
                    err = surface_error(gpis.mesh(resolution=48), truth, n_samples=5000,
                                        sharp_edges=np.zeros((0, 2, 3)))
                    curve.append((n, err.position_rmse_mm, err.normal_rmse_deg))
                except ValueError:
                    pass
                eval_s[0] += time.perf_counter() - t0

        error: BaseException | None = None
        try:
            loop.run(after_touch)
        except BaseException as exc:  # keep what was recorded, then re-raise
            error = exc
            raise
        finally:
            sim_time_s = scene.arm.time_s()
            metrics = _finish(loop, gpis, truth, planner, prior, out_dir, recorder, settings, curve,
                              sim_time_s, time.perf_counter() - wall0, eval_s[0], error)
    return RunResult(loop.records, gpis, metrics, out_dir)


def _finish(loop, gpis, truth, planner, prior, out_dir, recorder, settings, curve, sim_time_s,
            wall_s, eval_s, error) -> dict:
    records = loop.records
    kinds = [r.kind for r in records]
    metrics: dict = dict(
        object=settings.object, robot=settings.robot, strategy=settings.strategy,
        seed=settings.seed, use_normals=settings.use_normals,
        touches=len(records), contacts=kinds.count("contact"), misses=kinds.count("miss"),
        unreachable=kinds.count("unreachable"), no_normal=kinds.count("no_normal"),
        realign=kinds.count("realign"), blocked=kinds.count("blocked"),
        wall_time_s=wall_s, simulated_time_s=sim_time_s,
        phase_times_s=loop.times.as_dict(), evaluation_time_s=eval_s,
        completed=error is None, machine=f"{platform.machine()}, python {platform.python_version()}",
    )
    mesh = None
    if gpis.n_contacts:
        try:
            mesh = gpis.mesh(resolution=settings.mesh_resolution)
            mesh.export(out_dir / "reconstruction.ply")
            recorder.reconstruction(mesh, gpis.n_contacts, sim_time_s)
        except ValueError as exc:
            metrics["reconstruction_error"] = str(exc)
    contacts = np.array([r.position_m for r in records if r.kind == "contact"]).reshape(-1, 3)
    normals = np.array([r.normal for r in records if r.kind == "contact"]).reshape(-1, 3)
    if mesh is not None:
        metrics.update(reconstruction_errors(mesh, truth, contacts, normals))
    metrics["reachable_fraction"] = reachable_fraction(planner, truth, n_samples=48, seed=settings.seed)
    metrics["error_curve"] = [dict(touches=n, position_rmse_mm=p, normal_rmse_deg=a) for n, p, a in curve]
    (out_dir / "metrics.json").write_text(json.dumps(jsonable(metrics), indent=2))
    if mesh is not None:
        _plots(out_dir, gpis, mesh, truth, contacts, curve, settings)
    recorder.close(error)
    return metrics


def _plots(out_dir, gpis, mesh, truth, contacts, curve, settings) -> None:
    from reconstruction import figures

    figures.error_coloured_views(mesh, truth, contacts, out_dir / "reconstruction_error.png")
    if curve:
        errors = np.array([[p * 1e-3 for _, p, _ in curve]])
        figures.error_vs_touches({settings.strategy: errors}, out_dir / "error_vs_touches.png",
                                 touches=[n for n, _, _ in curve])
    figures.potential_slice(gpis if settings.use_normals else None,
                            None if settings.use_normals else gpis, truth,
                            path=out_dir / "potential_slice.png")
