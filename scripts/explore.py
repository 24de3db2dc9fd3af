"""``tactile-explore``: a headless exploration of one object (the project's main job).

    tactile-explore --object banana --touches 50 --out results/banana       # simulation
    tactile-explore --config rig.toml --out results/mug                     # configured rig
    tactile-explore --config rig.toml --out results/mug --resume            # go on after a stop

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
    from explorer.strategies import STRATEGIES

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", type=Path, help="rig configuration (.toml or .json); see explorer/config.py")
    parser.add_argument("--object", help=f"registry name ({', '.join(objects.names())}) or a mesh file in "
                                         f"metres (default banana; simulation only)")
    parser.add_argument("--robot", help=f"one of {', '.join(robots.names())} (default armar3; simulation only)")
    parser.add_argument("--strategy", choices=sorted(STRATEGIES), help="default variance")
    parser.add_argument("--touches", type=int, help="touch budget (default 50)")
    parser.add_argument("--seed", type=int)
    parser.add_argument("--no-normals", action="store_true", help="classic GPIS without normals")
    parser.add_argument("--out", type=Path, default=Path("results/explore"))
    parser.add_argument("--resume", action="store_true",
                        help="continue the stopped run in --out from its recorded contacts")
    parser.add_argument("--gui", action="store_true", help="show the PyBullet window (simulation only)")
    parser.add_argument("--profile", help="simulation profile: ideal, datasheet-noise (default), hardware-like "
                                          "or a .toml file (sensor/sim/profile.py); simulation only")
    args = parser.parse_args(argv)
    if args.touches is not None and args.touches < 1:
        parser.error("--touches must be at least 1")
    overrides = {k: v for k, v in dict(strategy=args.strategy, touches=args.touches, seed=args.seed).items()
                 if v is not None}
    if args.no_normals:
        overrides["use_normals"] = False
    if args.profile is not None:
        from sensor.sim.profile import get_profile

        try:
            get_profile(args.profile)
        except ValueError as error:
            parser.error(str(error))

    import torch

    # The loop's tensors are small (IK batches, one GP row block): extra intra-op threads only
    # add synchronisation, and on a loaded machine they spin (measured: IK 50x slower).
    torch.set_num_threads(1)
    if args.config is None:
        from explorer.run import RunSettings, explore

        settings = dataclasses.replace(RunSettings(object=args.object or "banana", robot=args.robot or "armar3",
                                                   gui=args.gui, profile=args.profile or "datasheet-noise"),
                                       **overrides)
        result = _with_progress(settings, lambda progress: explore(settings, args.out, progress, args.resume))
    else:
        for flag, value in (("--object", args.object), ("--robot", args.robot), ("--gui", args.gui or None),
                            ("--profile", args.profile)):
            if value is not None:
                parser.error(f"{flag} does not go with --config: set it in the configuration file")
        from explorer.config import load_config
        from explorer.rig import open_rig, run_settings
        from explorer.run import run_on_rig

        try:
            config = load_config(args.config)
        except (OSError, ValueError) as error:
            parser.error(str(error))
        settings = dataclasses.replace(run_settings(config), **overrides)

        def run(progress):
            with open_rig(config) as rig:
                return run_on_rig(rig, settings, args.out, progress, args.resume)

        result = _with_progress(settings, run)
    if result is None:
        return 1
    print(json.dumps({k: result.metrics.get(k) for k in SUMMARY_KEYS}, indent=2))
    print(f"outputs in {args.out}")
    return 0


def _with_progress(settings, run):
    """Run with a progress bar; a failed run prints what stopped it and where its records are."""
    from tqdm import tqdm

    with tqdm(total=settings.touches, unit="touch", desc=f"{settings.object}/{settings.strategy}") as bar:
        def progress(record):
            bar.update(1)
            bar.set_postfix_str(record.kind)

        try:
            return run(progress)
        except Exception as error:  # noqa: BLE001 - a device that failed: report it, keep the records
            bar.close()
            device = getattr(error, "device", None)
            print(f"run stopped: {type(error).__name__}: {error}" + (f" (device: {device})" if device else ""),
                  file=sys.stderr)
            print("everything recorded so far is kept; continue with --resume once the device is back",
                  file=sys.stderr)
            return None


if __name__ == "__main__":
    sys.exit(main())
