"""Evaluate the simulated arm + fingertip sensor: contact detection, normal accuracy, speed.

Runs headless and seeded (see explorer.sensor_evaluation). Prints a table, or with --json one JSON object
with the keys detection, normal_error_deg, normal_error_mean_deg, normal_error_noiseless_mean_deg
and speed_realtime_factor (plus supporting figures). Progress goes to stderr.

    tactile-sensor-eval [--presses 100] [--seed 0] [--json] [--out DIR]
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def _non_negative_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {value}")
    return value


def _non_negative_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not value >= 0.0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {value}")
    return value


def build_parser() -> argparse.ArgumentParser:
    from explorer.sensor_evaluation.scene import SUPPORTED_OBJECTS

    parser = argparse.ArgumentParser(prog="tactile-sensor-eval", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--presses", type=_non_negative_int, default=100, help="detection presses (default 100)")
    parser.add_argument("--seed", type=int, default=0, help="root seed (default 0)")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of the table")
    parser.add_argument("--out", default=None, help="also write the figures (PNG) into this folder")
    parser.add_argument("--robot", default="armar3", help="robot from the registry (default armar3)")
    parser.add_argument("--objects", nargs="+", default=list(SUPPORTED_OBJECTS), metavar="NAME",
                        help=f"detection objects, from: {', '.join(SUPPORTED_OBJECTS)}")
    parser.add_argument("--free-motion", type=_non_negative_int, default=10, help="free-motion trials (default 10)")
    parser.add_argument("--tilts", type=_non_negative_float, nargs="+", default=[0, 10, 20, 30, 40, 50],
                        metavar="DEG", help="plane tilts of the normal experiment, degrees")
    parser.add_argument("--normal-presses", type=_non_negative_int, default=10,
                        help="presses per tilt in the normal experiment (default 10)")
    parser.add_argument("--benchmark-seconds", type=_non_negative_float, default=5.0,
                        help="simulated seconds of the robots speed benchmark; 0 skips it (default 5)")
    parser.add_argument("--profile", default="datasheet-noise",
                        help="simulation profile: ideal, datasheet-noise (default), hardware-like or a .toml file")
    parser.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    return parser


def main(argv: list[str] | None = None) -> int:
    from scripts._cli import check_out_dir, check_robot

    parser = build_parser()
    args = parser.parse_args(argv)
    check_robot(parser, args.robot)
    if args.seed < 0:
        parser.error(f"argument --seed: must be at least 0, got {args.seed}")
    if args.out is not None:
        check_out_dir(parser, Path(args.out))
    from explorer.sensor_evaluation import EvaluationConfig, format_table, run_evaluation, to_json_dict, write_figures
    from explorer.sim_profile import get_profile

    try:
        config = EvaluationConfig(profile=get_profile(args.profile), presses=args.presses, seed=args.seed, objects=tuple(args.objects),
                                  free_motion_trials=args.free_motion, normal_tilts_deg=tuple(args.tilts),
                                  normal_presses_per_tilt=args.normal_presses, robot=args.robot,
                                  robots_benchmark_s=args.benchmark_seconds)
    except ValueError as err:
        parser.error(str(err))
    progress = None if args.quiet else (lambda line: print(line, file=sys.stderr, flush=True))
    try:
        report = run_evaluation(config, progress=progress)
    except ValueError as err:  # e.g. an unknown robot
        parser.error(str(err))
    figures = write_figures(report, args.out) if args.out else []
    if args.json:
        data = to_json_dict(report)
        data["figures"] = [str(p) for p in figures]
        print(json.dumps(data, allow_nan=False))
    else:
        print(format_table(report))
        for path in figures:
            print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
