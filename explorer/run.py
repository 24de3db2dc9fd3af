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
import warnings
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from explorer.coverage import reachable_fraction
from explorer.evaluation import jsonable, reconstruction_errors
from explorer.loop import LOOP_SETTLING, ExplorationLoop, LoopConfig, TouchRecord
from explorer.planner import ApproachPlanner, PlannerConfig
from explorer.recording import RunRecorder
from explorer.resume import check_resumable, load_recorded_run, resume_time_offset, rewrite_contacts_csv
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
    profile: str = "datasheet-noise"
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


@dataclass
class Rig:
    """What a run explores with; simulated and hardware rigs are built the same way.

    Attributes
    ----------
    robot : robots.interface.Robot
    sensor : sensor.interface.TactileSensor
        Opened by whoever built the rig.
    kinematics : robots.kinematics.ArmKinematics
        Of the robot's URDF.
    positioner : Positioner
        Holds the object; its pose carries contacts into the object frame.
    prior : ObjectPrior
        The object's rough location and size, object frame.
    reference : trimesh.Trimesh or None
        The true surface, object frame, metres, for error metrics (None on hardware without one).
    description : dict
        Session metadata: ``robot``, ``sensor``, ``object``, ``backend``.
    alignment : sensor.normal_estimation.ImuAlignment or None
        The sensor's calibrated IMU mounting (None: identity, as in simulation).
    """

    robot: object
    sensor: object
    kinematics: object
    positioner: object
    prior: ObjectPrior
    reference: object | None
    description: dict
    alignment: object | None = None


def explore(settings: RunSettings, out_dir: Path, progress=None, resume: bool = False) -> RunResult:
    """Run one simulated exploration and write its outputs to ``out_dir``.

    With ``resume=True`` the run already in ``out_dir`` is continued to ``settings.touches``
    (see :func:`run_on_rig`).
    """
    with build_scene(settings.object, settings.robot, seed=settings.seed, gui=settings.gui,
                     profile=settings.profile) as scene:
        truth = scene.object_model.mesh
        rig = Rig(scene.arm, scene.sensor, scene.kinematics, scene.stand, object_prior(truth), truth,
                  dict(robot=settings.robot, sensor="simulated BNO055 + BMP280 under polyurethane",
                       object=settings.object, backend="simulation", profile=scene.profile.name,
                       profile_parameters=scene.profile.changed_parameters()))
        return run_on_rig(rig, settings, out_dir, progress, resume)


def run_on_rig(rig: Rig, settings: RunSettings, out_dir: Path, progress=None, resume: bool = False) -> RunResult:
    """Explore with ``rig`` and write the run's outputs to ``out_dir`` (see the module docstring).

    Whatever stops the run (a device that stops answering, Ctrl-C), what was recorded stays on
    disk, the metrics and mesh are written from it, and the exception is re-raised. A device
    error names the device; the hardware arm stops itself when a call fails while it moves.

    Parameters
    ----------
    resume : bool
        Continue the run already in ``out_dir``: its touches are read back from the session
        (:mod:`explorer.resume`), the GPIS and the strategy's bookkeeping are rebuilt from them,
        and the loop goes on to ``settings.touches``, appending to the same files. Settings other
        than the budget and the evaluation must be the recorded ones.
    """
    from robots.ik import PadIK

    out_dir = Path(out_dir)
    wall0 = time.perf_counter()
    loop_settings = LoopConfig(**{**asdict(settings.loop), "touches": settings.touches})
    prior = rig.prior
    planner = ApproachPlanner(rig.kinematics, PadIK(rig.kinematics), rig.positioner, prior, settings.planner)
    gpis = GPIS(bounds=prior.bounds(), use_normals=settings.use_normals)
    configuration = dict(asdict(settings), detector=asdict(PressureDetectorConfig()),
                         settling=asdict(SettlingConfig(**LOOP_SETTLING)),
                         stand_centre_m=rig.positioner.centre_m,
                         prior=dict(centre_m=prior.centre_m, half_extent_m=prior.half_extent_m))
    metadata = dict(rig.description, seed=settings.seed, configuration=jsonable(configuration))
    recorded = None
    time_offset_s = 0.0
    if resume:
        recorded = load_recorded_run(out_dir)
        check_resumable(recorded.metadata.get("configuration", {}), jsonable(configuration))
        time_offset_s = resume_time_offset(recorded.end_time_s, rig.robot.time_s())
        rewrite_contacts_csv(out_dir, recorded.touches)
    recorder = RunRecorder(out_dir, metadata, resume=resume, time_offset_s=time_offset_s)
    loop = ExplorationLoop(rig.robot, rig.sensor, rig.kinematics, planner, rig.positioner,
                           make_strategy(settings.strategy, settings.seed), prior, gpis,
                           loop_settings, recorder, alignment=rig.alignment)
    if recorded is not None:
        loop.restore(recorded.touches)
        recorder.event("resumed", rig.robot.time_s(), time_offset_s=time_offset_s,
                       restored_touches=len(recorded.touches), restored_contacts=len(recorded.contacts),
                       touches=settings.touches)
    curve: list[tuple[int, float, float]] = []
    eval_s = [0.0]

    def after_touch(record: TouchRecord) -> None:
        if progress is not None:
            progress(record)
        n = len(loop.records)
        if (rig.reference is not None and settings.eval_every and n % settings.eval_every == 0
                and gpis.n_contacts >= 4):
            t0 = time.perf_counter()
            try:
                err = surface_error(gpis.mesh(resolution=48), rig.reference, n_samples=5000,
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
        _record_error(recorder, rig, exc)
        raise
    finally:
        try:
            metrics = _finish(loop, gpis, rig, planner, out_dir, recorder, settings, curve,
                              _safe_time(rig.robot), time.perf_counter() - wall0, eval_s[0], error)
        except Exception as finish_error:
            if error is None:
                raise
            # Raising here would replace the error that stopped the run; the records are on disk.
            recorder.close(error)
            warnings.warn(f"the run stopped ({type(error).__name__}) and its outputs could not all be "
                          f"written: {type(finish_error).__name__}: {finish_error}", RuntimeWarning)
    return RunResult(loop.records, gpis, metrics, out_dir)


def _record_error(recorder: RunRecorder, rig: Rig, error: BaseException) -> None:
    """An ``error`` event naming the failed device; never hides ``error`` itself."""
    t_s = _safe_time(rig.robot)
    if not np.isfinite(t_s):
        t_s = recorder.latest_time_s
    try:
        recorder.event("error", t_s, source=_device_of(error), message=f"{type(error).__name__}: {error}")
    except Exception:  # noqa: BLE001 - e.g. the disk is full; the original error is what matters
        pass


def _safe_time(robot) -> float:
    """The robot's clock, or NaN when the robot itself is what failed."""
    try:
        return float(robot.time_s())
    except Exception:  # noqa: BLE001 - reporting time must not hide the original error
        return float("nan")


def _device_of(error: BaseException) -> str:
    """The device an error names (hardware errors carry ``device``), else the exception type."""
    return str(getattr(error, "device", None) or type(error).__name__)


def _finish(loop, gpis, rig, planner, out_dir, recorder, settings, curve, robot_time_s, wall_s, eval_s,
            error) -> dict:
    records = loop.records
    truth = rig.reference
    kinds = [r.kind for r in records]
    metrics: dict = dict(
        object=rig.description.get("object", settings.object), robot=settings.robot,
        backend=rig.description.get("backend"), strategy=settings.strategy,
        seed=settings.seed, use_normals=settings.use_normals,
        touches=len(records), contacts=kinds.count("contact"), misses=kinds.count("miss"),
        unreachable=kinds.count("unreachable"), no_normal=kinds.count("no_normal"),
        realign=kinds.count("realign"), blocked=kinds.count("blocked"),
        wall_time_s=wall_s, simulated_time_s=robot_time_s,
        phase_times_s=loop.times.as_dict(), evaluation_time_s=eval_s,
        completed=error is None, machine=f"{platform.machine()}, python {platform.python_version()}",
    )
    if error is not None:
        metrics["error"] = dict(device=_device_of(error), type=type(error).__name__, message=str(error))
    mesh = None
    if gpis.n_contacts:
        try:
            mesh = gpis.mesh(resolution=settings.mesh_resolution)
            mesh.export(out_dir / "reconstruction.ply")
            recorder.reconstruction(mesh, gpis.n_contacts, recorder.latest_time_s)
        except ValueError as exc:
            metrics["reconstruction_error"] = str(exc)
    contacts = np.array([r.position_m for r in records if r.kind == "contact"]).reshape(-1, 3)
    normals = np.array([r.normal for r in records if r.kind == "contact"]).reshape(-1, 3)
    if mesh is not None and truth is not None:
        metrics.update(reconstruction_errors(mesh, truth, contacts, normals))
    if truth is not None:
        metrics["reachable_fraction"] = reachable_fraction(planner, truth, n_samples=48, seed=settings.seed)
    metrics["error_curve"] = [dict(touches=n, position_rmse_mm=p, normal_rmse_deg=a) for n, p, a in curve]
    if mesh is not None:
        try:
            _plots(out_dir, gpis, mesh, truth, contacts, curve, settings)
        except ValueError as exc:  # e.g. too few contacts to frame a figure: say so, keep the rest
            metrics["figure_error"] = str(exc)
    (out_dir / "metrics.json").write_text(json.dumps(jsonable(metrics), indent=2))
    recorder.close(error)
    return metrics


def _plots(out_dir, gpis, mesh, truth, contacts, curve, settings) -> None:
    from reconstruction import figures

    if truth is not None:
        figures.error_coloured_views(mesh, truth, contacts, out_dir / "reconstruction_error.png")
    if curve:
        errors = np.array([[p * 1e-3 for _, p, _ in curve]])
        figures.error_vs_touches({settings.strategy: errors}, out_dir / "error_vs_touches.png",
                                 touches=[n for n, _, _ in curve])
    # Without the truth the slice goes through the contacts (a one-sided touch set may not reach z = 0).
    offset_m = 0.0 if truth is not None or not len(contacts) else float(np.median(contacts[:, 2]))
    figures.potential_slice(gpis if settings.use_normals else None,
                            None if settings.use_normals else gpis, truth, offset_m=offset_m,
                            path=out_dir / "potential_slice.png")
