"""``tactile-explore``: a headless exploration of one object (the project's main job).

    tactile-explore --object banana --touches 50 --out results/banana       # simulation
    tactile-explore --config rig.toml --out results/mug                     # configured rig
    tactile-explore --config rig.toml --out results/mug --resume            # go on after a stop
    tactile-explore --object banana --touches 20 --rerun run.rrd            # also log to Rerun

Without ``--config`` the object is explored in simulation on a turntable-and-tilt stand. With
``--config`` the robot, sensor, object and exploration settings come from the file
(``explorer/config.py`` documents it; ``configs/`` has one per backend) and the object stays in
place. ``--resume`` continues the run in ``--out`` from its recorded contacts to the budget.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

SUMMARY_KEYS = ("touches", "contacts", "misses", "position_rmse_mm", "normal_rmse_deg", "coverage",
                "reachable_fraction", "wall_time_s", "simulated_time_s")


def main(argv: list[str] | None = None) -> int:
    import objects
    import robots
    from explorer.rerun_view import add_rerun_argument, observer_from_argument
    from explorer.strategies import STRATEGIES
    from scripts._cli import check_gui, check_object, check_out_dir, check_robot, float_above, int_at_least

    parser = argparse.ArgumentParser(prog="tactile-explore", description=__doc__.splitlines()[0])
    parser.add_argument("--config", type=Path, help="rig configuration (.toml or .json); see explorer/config.py")
    parser.add_argument("--object", help=f"registry name ({', '.join(objects.names())}), generated:FAMILY/SEED "
                                         f"or a mesh file (default banana; simulation only)")
    parser.add_argument("--units", choices=("m", "cm", "mm", "in"), default="m",
                        help="length unit of a mesh file given as the object (default m)")
    parser.add_argument("--robot", help=f"one of {', '.join(robots.names())} (default armar3; simulation only)")
    parser.add_argument("--strategy", choices=sorted(STRATEGIES), help="default variance")
    parser.add_argument("--touches", type=int_at_least(1), help="touch budget (default 50)")
    parser.add_argument("--seed", type=int_at_least(0), help="random seed, >= 0 (default 0)")
    parser.add_argument("--no-normals", action="store_true", help="classic GPIS without normals")
    parser.add_argument("--no-symmetry", action="store_true",
                        help="mesh without the contacts' images under the symmetry they support "
                             "(LoopConfig.reconstruction_symmetry; for an object known to be almost, not quite, symmetric)")
    parser.add_argument("--out", type=Path, default=Path("results/explore"),
                        help="output directory: new or empty (or the run to continue, with --resume)")
    parser.add_argument("--resume", action="store_true",
                        help="continue the stopped run in --out from its recorded contacts")
    parser.add_argument("--gui", action="store_true", help="show the PyBullet window (simulation only)")
    parser.add_argument("--profile", help="simulation profile: ideal, datasheet-noise (default), hardware-like "
                                          "or a .toml file (explorer/sim_profile.py); simulation only")
    parser.add_argument("--calibration", type=Path, metavar="FILE",
                        help="joint calibration of this robot, profile and seed (joint_calibration.json of "
                             "scripts.calibrate_joints) applied to the simulated arm; simulation only")
    parser.add_argument("--probe-depth", type=float_above(0.0, inclusive=True), metavar="MM",
                        help="how far past its target a touch may probe before it is a miss, mm (default 150; "
                             "a configuration file's exploration.probe_depth_m)")
    parser.add_argument("--reach-samples", type=int_at_least(0), metavar="N",
                        help="surface samples of metrics.json's reach_breakdown (default 64; 0 skips it, "
                             "python -m scripts.reach_report computes it later; exploration.reach_samples)")
    add_rerun_argument(parser)
    args = parser.parse_args(argv)
    overrides = {k: v for k, v in dict(strategy=args.strategy, touches=args.touches, seed=args.seed,
                                       reach_samples=args.reach_samples).items() if v is not None}
    if args.no_normals:
        overrides["use_normals"] = False
    if args.probe_depth is not None:
        from explorer.planner import PlannerConfig

        overrides["planner"] = PlannerConfig(probe_depth_m=args.probe_depth / 1e3)
    if args.config is None:
        check_object(parser, args.object)
        check_robot(parser, args.robot)
        if args.gui:
            check_gui(parser)
    else:
        for flag, value in (("--object", args.object), ("--robot", args.robot), ("--gui", args.gui or None),
                            ("--units", None if args.units == "m" else args.units), ("--profile", args.profile),
                            ("--calibration", args.calibration)):
            if value is not None:
                parser.error(f"{flag} does not go with --config: set it in the configuration file")
    if args.profile is not None:
        from explorer.sim_profile import get_profile

        try:
            profile = get_profile(args.profile)
        except ValueError as error:
            parser.error(f"--profile: {error}")
        if args.calibration is None and not args.resume and (profile.joint_offset_std_deg or profile.link_length_std_mm):
            print(f"tactile-explore: note: profile {profile.name!r} draws the arm's calibration errors (joint offsets "
                  f"{profile.joint_offset_std_deg:g} deg, link lengths {profile.link_length_std_mm:g} mm RMS) and this run "
                  f"does not calibrate them, so its contacts carry them (4-5 mm RMS on ARMAR-III), as an uncalibrated lab arm's do. "
                  f"Calibrate first: python -m scripts.calibrate_joints --profile {args.profile} --robot "
                  f"{args.robot or 'armar3'} --seed {args.seed or 0} --out DIR, then --calibration "
                  f"DIR/joint_calibration.json", file=sys.stderr)
    if args.calibration is not None:
        _check_calibration(parser, args)
    check_out_dir(parser, args.out, resume=args.resume)
    if args.config is None:
        try:
            object_name = objects.in_metres(args.object or "banana", args.units)
        except (ValueError, FileNotFoundError) as error:
            parser.error(str(error))
    observer = observer_from_argument(parser, args.rerun, "tactile-explore")

    import torch

    # The loop's tensors are small (IK batches, one GP row block): extra intra-op threads only
    # add synchronisation, and on a loaded machine they spin (measured: IK 50x slower).
    torch.set_num_threads(1)
    if args.config is None:
        from explorer.run import RunSettings, explore

        settings = dataclasses.replace(RunSettings(object=object_name, robot=args.robot or "armar3",
                                                   gui=args.gui, profile=args.profile or "datasheet-noise",
                                                   calibration=None if args.calibration is None else str(args.calibration)),
                                       **overrides)
        settings = _without_symmetry(settings) if args.no_symmetry else settings

        def run(progress, status):
            return explore(settings, args.out, progress, args.resume, observer, status=status)
    else:
        from explorer.config import load_config
        from explorer.backends import open_rig, run_settings
        from explorer.run import run_on_rig

        try:
            config = load_config(args.config)
        except (OSError, ValueError) as error:
            parser.error(str(error))
        settings = dataclasses.replace(run_settings(config), **overrides)
        settings = _without_symmetry(settings) if args.no_symmetry else settings

        def run(progress, status):
            with open_rig(config) as rig:
                return run_on_rig(rig, settings, args.out, progress, args.resume, observer, status=status)

    result, status = _with_progress(settings, run, args.out, args.resume)
    if result is None:
        return status
    print(json.dumps({k: result.metrics.get(k) for k in SUMMARY_KEYS}, indent=2))
    print(f"outputs in {args.out}")
    return 0


def _check_calibration(parser: argparse.ArgumentParser, args) -> None:
    """``--calibration`` must be a readable calibration of this run's robot, profile and seed."""
    from explorer.arm_calibration import read_arm_calibration

    try:
        calibration = read_arm_calibration(args.calibration)
    except ValueError as error:
        parser.error(f"--calibration: {error}")
    from explorer.sim_profile import PROFILES

    run = (args.robot or "armar3", args.profile or "datasheet-noise", 0 if args.seed is None else args.seed)
    profile_known = run[1] in PROFILES  # a profile file's name is checked once it is loaded
    if (calibration.robot, calibration.seed) != (run[0], run[2]) or (profile_known and calibration.profile != run[1]):
        parser.error(f"--calibration {args.calibration} is of robot {calibration.robot!r}, profile "
                     f"{calibration.profile!r}, seed {calibration.seed}; this run is {run[0]!r}, {run[1]!r}, seed "
                     f"{run[2]}: give the same --robot, --profile and --seed (the seed draws the arm's errors)")


def _is_device_failure(error: BaseException) -> bool:
    """A sensor chip, arm controller or their link failed (not a bad argument or a bug)."""
    from robots.hardware.errors import RobotHardwareError
    from sensor.drivers.errors import DeviceError

    return isinstance(error, (DeviceError, RobotHardwareError, ConnectionError)) or bool(getattr(error, "device", None))


def _recorded_touches(out: Path) -> int:
    """Touches already recorded in the run in ``out`` (the progress bar starts there on --resume)."""
    import warnings

    from explorer.resume import load_recorded_run

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            return len(load_recorded_run(out).touches)
        except (OSError, ValueError):
            return 0


def _with_progress(settings, run, out: Path, resume: bool):
    """Run with a progress bar; returns ``(result, 0)`` or ``(None, exit status)``.

    Whatever stops the run, one line says what and where its records are: a device failure
    suggests ``--resume`` once the device is back, Ctrl-C suggests ``--resume``, and an error
    raised before anything was recorded (a bad setting) is a usage error (exit 2) that leaves
    nothing behind.
    """
    from tqdm import tqdm

    existed = out.exists()
    session_before = _session_size(out)
    initial = _recorded_touches(out) if resume else 0
    bars: dict = {}
    with tqdm(total=max(settings.touches, initial), initial=initial, unit="touch",
              desc=f"{settings.object}/{settings.strategy}") as bar:
        def progress(record):
            bar.update(1)
            bar.set_postfix_str(record.kind)

        def status(step, done, total):
            if step not in bars:
                bar.refresh()
                bars[step] = tqdm(total=total, desc=f"finishing: {step}", leave=False)
            bars[step].n = done
            bars[step].refresh()

        try:
            return run(progress, status), 0
        except KeyboardInterrupt:
            kept = _session_size(out) > session_before
            message = (f"interrupted: everything recorded so far is kept in {out}; continue with --resume"
                       if kept else "interrupted before anything was recorded")
        except Exception as error:  # noqa: BLE001 - one line, never a traceback
            device = getattr(error, "device", None)
            what = f"{type(error).__name__}: {error}" + (f" (device: {device})" if device else "")
            if _is_device_failure(error):
                message = (f"run stopped: {what}\neverything recorded so far is kept in {out}; "
                           f"continue with --resume once the device is back")
            elif _session_size(out) > session_before:
                message = f"run stopped: {what}\neverything recorded so far is kept in {out}; continue with --resume"
            else:
                for bar_ in bars.values():
                    bar_.close()
                bar.close()
                if not existed:
                    _remove_if_empty(out)
                print(f"tactile-explore: error: {error}", file=sys.stderr)
                return None, 2
        finally:
            for bar_ in bars.values():
                bar_.close()
    print(message, file=sys.stderr)
    return None, 130 if message.startswith("interrupted") else 1


def _session_size(out: Path) -> int:
    """Bytes recorded in ``out/session`` (0 when there is none)."""
    session = out / "session"
    if not session.is_dir():
        return 0
    return sum(p.stat().st_size for p in session.iterdir() if p.is_file())


def _remove_if_empty(path: Path) -> None:
    """Remove ``path`` and its empty subdirectories if no file was written there."""
    if not path.is_dir():
        return
    for child in sorted(path.rglob("*"), reverse=True):
        if child.is_dir() and not any(child.iterdir()):
            child.rmdir()
    if not any(path.iterdir()):
        path.rmdir()


if __name__ == "__main__":
    sys.exit(main())


def _without_symmetry(settings):
    """``settings`` with the run's mesh made without the contacts' symmetric images."""
    return dataclasses.replace(settings, loop=dataclasses.replace(settings.loop, reconstruction_symmetry=False))
