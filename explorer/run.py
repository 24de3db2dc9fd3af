"""A whole simulated exploration run: scene, loop, outputs. The main job of the project.

Writes to the output directory, as the run goes:

* ``session/``          everything the run saw (sensor stream, joint states, contacts, events);
* ``contacts.csv``      one row per contact, object frame, metres, outward normals;

and at the end (also after an interruption, from what was recorded):

* ``reconstruction.ply`` the GPIS mean surface, object frame;
* ``metrics.json``       errors against the ground truth, touches, misses, blocked moves
                         (``blocked_moves``: protective stops by phase and by what the arm met),
                         coverage, times, and with a
                         ground truth (and ``reach_samples`` > 0) ``reach_breakdown`` (:class:`explorer.coverage.ReachBreakdown`:
                         surface fractions where the pad does not fit, the arm cannot reach, the stand
                         hides it, reachable but untouched, touched), ``reachable_fraction`` and
                         ``coverage_ceiling`` (the most coverage the run's contacts could give), and
                         ``coverage_placed`` (what as many contacts placed greedily on the true surface
                         cover, the arm ignored: :func:`explorer.coverage.placed_coverage`);
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

import objects
from explorer.evaluation import jsonable
from explorer.config import ExplorationConfig
from explorer.contact import LOOP_SETTLING
from explorer.coverage import coverage_ceiling, placed_coverage, reach_breakdown
from explorer.loop import ExplorationLoop, LoopConfig
from explorer.observer import ObservedStrategy
from explorer.outputs import add_errors, kept_contacts, reconstruction_counts, write_figures, write_json, write_mesh
from explorer.planner import ApproachPlanner, PlannerConfig
from explorer.recording import RunRecorder
from explorer.resume import check_resumable, load_recorded_run, resume_time_offset, rewrite_contacts_csv
from explorer.rig import Rig, object_prior
from explorer.simulation import build_scene
from explorer.strategies import make_strategy
from explorer.touch import TouchOutcome, left_line_counts
from reconstruction.gpis import GPIS
from reconstruction.metrics import surface_error
from sensor.contact_detection import PressureDetectorConfig


@dataclass
class RunSettings:
    """Everything that defines a run (saved in the session metadata).

    The defaults shared with a configuration file's ``[exploration]`` are
    :class:`explorer.config.ExplorationConfig`'s (one source for both).
    """

    object: str = "banana"
    robot: str = "armar3"
    strategy: str = ExplorationConfig.strategy
    touches: int = ExplorationConfig.touches
    seed: int = ExplorationConfig.seed
    profile: str = "datasheet-noise"
    calibration: str | None = None
    use_normals: bool = ExplorationConfig.use_normals
    gui: bool = False
    eval_every: int = ExplorationConfig.eval_every
    mesh_resolution: int = ExplorationConfig.mesh_resolution
    reach_samples: int = ExplorationConfig.reach_samples
    loop: LoopConfig = field(default_factory=LoopConfig)
    planner: PlannerConfig = field(default_factory=PlannerConfig)


@dataclass
class RunResult:
    records: list[TouchOutcome]
    gpis: GPIS
    metrics: dict
    out_dir: Path


def explore(settings: RunSettings, out_dir: Path, progress=None, resume: bool = False,
            observer=None, *, status=None) -> RunResult:
    """Run one simulated exploration and write its outputs to ``out_dir``.

    With ``resume=True`` the run already in ``out_dir`` is continued to ``settings.touches``
    (see :func:`run_on_rig`); ``observer`` as there.
    """
    calibration = None
    if settings.calibration:
        from explorer.arm_calibration import read_arm_calibration

        calibration = read_arm_calibration(settings.calibration)
    with build_scene(settings.object, settings.robot, seed=settings.seed, gui=settings.gui,
                     profile=settings.profile) as scene:
        truth = scene.object_model.mesh
        robot, kinematics = scene.arm, scene.kinematics
        if calibration is not None:
            from explorer.arm_calibration import calibrated_arm

            arm = (calibration.robot, calibration.profile, calibration.seed)
            if arm != (settings.robot, scene.profile.name, settings.seed):
                raise ValueError(f"calibration {settings.calibration} is of robot {arm[0]!r}, profile {arm[1]!r}, "
                                 f"seed {arm[2]}; this run is {settings.robot!r}, {scene.profile.name!r}, seed "
                                 f"{settings.seed} (the seed draws the arm's errors): calibrate this arm")
            robot, kinematics = calibrated_arm(scene.arm, scene.kinematics, calibration)
        rig = Rig(robot, scene.sensor, kinematics, scene.stand, object_prior(truth), truth,
                  dict(robot=settings.robot, sensor="simulated BNO055 + BMP280 under polyurethane",
                       object=settings.object, backend="simulation", profile=scene.profile.name,
                       **objects.shift_record(scene.object_model),
                       profile_parameters=scene.profile.changed_parameters(),
                       calibration=None if calibration is None else dict(
                           offset_rad=calibration.offset_rad.tolist(),
                           link_length_error_m=calibration.link_length_error_m)), scene.pad,
                  obstacles=() if scene.world.table is None else (scene.world.table.box_m(),))
        return run_on_rig(rig, settings, out_dir, progress, resume, observer, status=status)


def run_on_rig(rig: Rig, settings: RunSettings, out_dir: Path, progress=None, resume: bool = False,
               observer=None, *, status=None) -> RunResult:
    """Explore with ``rig`` and write the run's outputs to ``out_dir`` (see the module docstring).

    Whatever stops the run (a device that stops answering, Ctrl-C), what was recorded stays on
    disk, the metrics and mesh are written from it, and the exception is re-raised. A device
    error names the device; the hardware arm stops itself when a call fails while it moves.
    Ctrl-C while the outputs are written skips the remaining slow steps (reachable fraction,
    figures) but still writes ``metrics.json`` and closes the session.

    Parameters
    ----------
    resume : bool
        Continue the run already in ``out_dir``: its touches are read back from the session
        (:mod:`explorer.resume`), the GPIS and the strategy's bookkeeping are rebuilt from them,
        and the loop goes on to ``settings.touches``, appending to the same files. Settings other
        than the budget and the evaluation must be the recorded ones. The figures of the earlier
        parts (``metrics.json``: error curve, wall / simulated / phase times) are carried over.
    observer : explorer.observer.RunObserver, optional
        Shown the run as it happens (e.g. :class:`explorer.rerun_view.RerunObserver`).
    status : callable(str, int, int) or None
        Told about the slow steps after the last touch: ``status(step, done, total)``.
    """
    from robots.ik import PadIK

    out_dir = Path(out_dir)
    wall0 = time.perf_counter()
    loop_settings = LoopConfig(**{**asdict(settings.loop), "touches": settings.touches})
    prior = rig.prior
    planner = ApproachPlanner(rig.kinematics, PadIK(rig.kinematics), rig.positioner, prior, settings.planner,
                              obstacles=rig.obstacles)
    _check_fits_the_rig(planner, rig)
    gpis = GPIS(bounds=prior.bounds(), use_normals=settings.use_normals)
    configuration = dict(asdict(settings), detector=asdict(PressureDetectorConfig()),
                         settling=asdict(LOOP_SETTLING), pad=rig.pad.as_dict(),
                         stand_centre_m=rig.positioner.centre_m, obstacles_m=list(rig.obstacles),
                         prior=dict(centre_m=prior.centre_m, half_extent_m=prior.half_extent_m))
    metadata = dict(rig.description, seed=settings.seed, configuration=jsonable(configuration))
    recorded = None
    time_offset_s = 0.0
    earlier: dict = {}
    if resume:
        recorded = load_recorded_run(out_dir)
        earlier = earlier_metrics(out_dir)
        check_resumable(recorded.metadata.get("configuration", {}), jsonable(configuration))
        time_offset_s = resume_time_offset(recorded.end_time_s, rig.robot.time_s())
        rewrite_contacts_csv(out_dir, recorded.touches)
    recorder = RunRecorder(out_dir, metadata, resume=resume, time_offset_s=time_offset_s, observer=observer)
    strategy = make_strategy(settings.strategy, settings.seed)
    if observer is not None:
        observer.run_started(rig, gpis, metadata)
        strategy = ObservedStrategy(strategy, observer, lambda: recorder.latest_time_s + recorder.time_offset_s)
    loop = ExplorationLoop(rig, planner, strategy, gpis, loop_settings, recorder)
    if recorded is not None:
        loop.restore(recorded.touches)
        recorder.event("resumed", rig.robot.time_s(), time_offset_s=time_offset_s,
                       restored_touches=len(recorded.touches), restored_contacts=len(recorded.contacts),
                       touches=settings.touches)
    curve: list[tuple[int, float, float]] = []
    eval_s = [0.0]

    def after_touch(record: TouchOutcome) -> None:
        if progress is not None:
            progress(record)
        n = len(loop.records)
        if (rig.reference is not None and settings.eval_every and n % settings.eval_every == 0
                and gpis.n_contacts >= 4):
            t0 = time.perf_counter()
            try:
                field = loop.config.reconstruction_field(gpis, loop.records, rig.pad)[0]
                err = surface_error(field.mesh(resolution=48, symmetry=loop.config.reconstruction_symmetry,
                                               refine_steps=loop.config.reconstruction_refine_steps),
                                    rig.reference, n_samples=5000,
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
                              _safe_time(rig.robot), time.perf_counter() - wall0, eval_s[0], error,
                              earlier=earlier, status=status)
        except Exception as finish_error:
            if error is None:
                raise
            # Raising here would replace the error that stopped the run; the records are on disk.
            recorder.close(error)
            warnings.warn(f"the run stopped ({type(error).__name__}) and its outputs could not all be "
                          f"written: {type(finish_error).__name__}: {finish_error}", RuntimeWarning)
    return RunResult(loop.records, gpis, metrics, out_dir)


def _check_fits_the_rig(planner: ApproachPlanner, rig: Rig) -> None:
    """ValueError, before anything is recorded, when the stand would turn the object's rough box
    into the arm waiting at rest: every later move would end on the object (a 50 cm crate stopped
    after its first contact with the wrist pressed against it)."""
    clearance = planner.rest_clearance_m()
    if clearance < 0:
        size = " x ".join(f"{2e3 * h:.0f}" for h in rig.prior.half_extent_m)
        raise ValueError(f"the object is too large for this rig: turned by the stand, its rough box ({size} mm, "
                         f"the object and a margin) reaches {-clearance * 1e3:.0f} mm into the arm waiting at rest; "
                         "explore a smaller object, or check the mesh's units (--units)")


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


def earlier_metrics(out_dir: Path) -> dict:
    """The ``metrics.json`` of the run in ``out_dir`` before it is resumed ({} if none or unreadable)."""
    try:
        metrics = json.loads((Path(out_dir) / "metrics.json").read_text())
    except (OSError, ValueError):
        return {}
    return metrics if isinstance(metrics, dict) else {}


def _carry_over(metrics: dict, earlier: dict, curve: list) -> list:
    """Add the earlier parts' times to ``metrics``; return the whole error curve (earlier points
    before the first new one, then the new ones)."""
    if not earlier:
        return [dict(touches=n, position_rmse_mm=p, normal_rmse_deg=a) for n, p, a in curve]
    for key in ("wall_time_s", "simulated_time_s", "evaluation_time_s"):
        if isinstance(earlier.get(key), (int, float)) and np.isfinite(metrics.get(key, np.nan)):
            metrics[key] = float(earlier[key]) + metrics[key]
    phases = dict(earlier.get("phase_times_s") or {})
    for phase, seconds in metrics["phase_times_s"].items():
        phases[phase] = float(phases.get(phase, 0.0)) + seconds
    metrics["phase_times_s"] = phases
    metrics["blocked_moves"] = _summed_counts(earlier.get("blocked_moves") or {}, metrics["blocked_moves"])
    metrics["parts"] = int(earlier.get("parts", 1)) + 1
    first_new = curve[0][0] if curve else np.inf
    kept = [point for point in earlier.get("error_curve") or [] if point.get("touches", np.inf) < first_new]
    return kept + [dict(touches=n, position_rmse_mm=p, normal_rmse_deg=a) for n, p, a in curve]


def _summed_counts(a: dict, b: dict) -> dict:
    """Nested count dicts added key by key (``{"retract": 2, "on": {"table": 1}}``)."""
    out = dict(a)
    for key, value in b.items():
        out[key] = _summed_counts(out.get(key) or {}, value) if isinstance(value, dict) else int(out.get(key, 0)) + value
    return out


def _finish(loop, gpis, rig, planner, out_dir, recorder, settings, curve, robot_time_s, wall_s, eval_s,
            error, earlier=None, status=None) -> dict:
    """Write the mesh, metrics and figures; close the session. Ctrl-C here skips the remaining slow
    steps, writes what is known and is re-raised after the session is closed."""
    interrupted: KeyboardInterrupt | None = None
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
        blocked_moves=loop.blocked_moves_summary(),
        doubtful=sum(bool(getattr(r.quality, "doubtful", False)) for r in records if r.kind == "contact"),
        repressed=sum(r.repress_t_s is not None for r in records),
        **left_line_counts(records),
        wall_time_s=wall_s, simulated_time_s=robot_time_s,
        phase_times_s=loop.times.as_dict(), evaluation_time_s=eval_s,
        completed=error is None, machine=f"{platform.machine()}, python {platform.python_version()}",
    )
    if objects.FILE_SHIFT_KEY in rig.description:
        metrics[objects.FILE_SHIFT_KEY] = rig.description[objects.FILE_SHIFT_KEY]
    if error is not None:
        metrics["error"] = dict(device=_device_of(error), type=type(error).__name__, message=str(error))
    metrics["error_curve"] = _carry_over(metrics, earlier or {}, curve)
    mesh = None
    contact_records = [r for r in records if r.kind == "contact"]
    contacts = np.array([r.position_m for r in contact_records]).reshape(-1, 3)
    normals = np.array([r.normal for r in contact_records]).reshape(-1, 3)
    try:
        built = loop.config.reconstruction(gpis, loop.records, rig.pad)
        gpis = built.field
        metrics.update(reconstruction_counts(built))
        mesh = write_mesh(gpis, settings.mesh_resolution, out_dir, metrics, loop.config.reconstruction_symmetry,
                          loop.config.reconstruction_refine_steps)
        if mesh is not None:
            recorder.reconstruction(mesh, gpis.n_contacts, recorder.latest_time_s)
        add_errors(metrics, mesh, truth, contacts, normals,
                   kept_contacts(contact_records, built.rim_standoff_touches))
        if truth is not None and settings.reach_samples > 0:
            steps = settings.reach_samples
            report = None if status is None else (lambda done: status("reachable fraction", done, steps))
            reach = reach_breakdown(truth, contacts, planner, n_samples=steps, seed=settings.seed, progress=report)
            metrics["reachable_fraction"] = reach.reachable
            metrics["reach_breakdown"] = reach.as_dict()
        if truth is not None:
            metrics["coverage_ceiling"] = coverage_ceiling(truth, len(contacts))
            metrics["coverage_placed"] = placed_coverage(truth, len(contacts))
        if mesh is not None:
            curve_points = [(c["touches"], c["position_rmse_mm"], c["normal_rmse_deg"]) for c in metrics["error_curve"]]
            try:
                write_figures(out_dir, gpis, mesh, truth, contacts, settings.use_normals, curve_points,
                              settings.strategy)
            except ValueError as exc:  # e.g. too few contacts to frame a figure: say so, keep the rest
                metrics["figure_error"] = str(exc)
    except KeyboardInterrupt as exc:  # keep what is known; the caller learns of the interrupt below
        interrupted = exc
        metrics["interrupted_while"] = "writing the outputs (reachable fraction, figures skipped)"
    write_json(out_dir / "metrics.json", jsonable(metrics))
    recorder.close(error if error is not None else interrupted)
    if interrupted is not None and error is None:
        raise interrupted
    return metrics

