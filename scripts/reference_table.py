"""The reference work's accuracy table like for like, every row under every simulation profile.

Simulation rows (box, sphere, cylinder, banana; ARMAR-III) are read under the default profile,
real-robot rows (ground coffee = coffee_can, Cheez-It = cereal_box, flat surface = flat on ARMAR-6;
bowl on ARMAR-III) under ``hardware-like`` with the arm calibrated from ball touches
(``scripts.calibrate_joints``, run first for each robot and seed). Every row also runs under each
``--profiles`` entry and, for hardware-like, uncalibrated, so the cost of each error source can be
read off. With normals: the run's own reconstruction; without normals, as the reference ran it: a
second exploration of the row's main column driven by the classic GPIS; beside both, the classic
GPIS refitted on the with-normals run's contacts (``explorer/reference_table.py``). Runs are sweep
runs on one process pool, resumable: run the command again with the same --out to finish what is
missing.
Writes ``reference_table.md`` and ``reference_table.json`` into --out.

    python -m scripts.reference_table --out DIR                 # 8 rows x 4 columns, 100 touches
    python -m scripts.reference_table --quick --out DIR         # sphere, 3 touches, default profile
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path


def build_parser() -> argparse.ArgumentParser:
    from scripts._cli import int_at_least

    parser = argparse.ArgumentParser(prog="reference_table", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, required=True, help="output directory (reused to resume)")
    parser.add_argument("--rows", default=None,
                        help="comma-separated objects (default all eight: box,sphere,cylinder,banana,coffee_can,"
                             "cereal_box,flat,bowl)")
    parser.add_argument("--profiles", default="ideal,datasheet-noise,hardware-like",
                        help="comma-separated profile columns (default all three)")
    parser.add_argument("--touches", type=int_at_least(1), default=100, help="touches per run (<= 100, default 100)")
    parser.add_argument("--seed", type=int_at_least(0), default=0)
    parser.add_argument("--workers", type=int_at_least(1), default=2, help="runs at a time")
    parser.add_argument("--calibration-touches", type=int_at_least(12), default=36,
                        help="ball touches of each robot's calibration (default 36)")
    parser.add_argument("--no-calibration", action="store_true", help="leave out the calibrated hardware-like column")
    parser.add_argument("--refit-only", action="store_true",
                        help="explore with normals only; without normals is then only the classic refit of the "
                             "same contacts (the like-for-like column stays empty)")
    parser.add_argument("--eval-every", type=int_at_least(0), default=0, help="touches between error evaluations")
    parser.add_argument("--mesh-resolution", type=int_at_least(8), default=96)
    parser.add_argument("--table-only", action="store_true",
                        help="run nothing: write the table from the runs already finished in --out")
    parser.add_argument("--quick", action="store_true",
                        help="the sphere row, 3 touches, default profile, no calibration, resolution 32 (a smoke test)")
    return parser


def main(argv: list[str] | None = None) -> int:
    from scripts._cli import check_out_dir

    parser = build_parser()
    args = parser.parse_args(argv)
    from explorer.reference_table import PROFILE_COLUMNS, ROWS, columns, rows_named
    from explorer.sim_profile import PROFILES

    if args.quick:
        args.rows = args.rows or "sphere"
        if argv is None or "--profiles" not in argv:
            args.profiles = "datasheet-noise"
        args.touches, args.no_calibration, args.mesh_resolution, args.workers = 3, True, 32, 1
    if args.touches > 100:
        parser.error(f"argument --touches: the reference's budget is at most 100, got {args.touches}")
    try:
        rows = rows_named(args.rows.split(",")) if args.rows else ROWS
    except ValueError as error:
        parser.error(f"argument --rows: {error}")
    profiles = tuple(p for p in args.profiles.split(",") if p)
    bad = [p for p in profiles if p not in PROFILES]
    if bad or not profiles:
        parser.error(f"argument --profiles: unknown {bad}; use some of {', '.join(PROFILE_COLUMNS)}")
    check_out_dir(parser, args.out, reusable=True)
    cols = columns(profiles, calibrated=not args.no_calibration)

    started = time.perf_counter()
    args.out.mkdir(parents=True, exist_ok=True)
    calibrations = {}
    if not args.no_calibration and "hardware-like" in profiles:
        calibrations = existing_calibrations(sorted({r.robot for r in rows}), args) if args.table_only \
            else calibrate(sorted({r.robot for r in rows}), args)
    from explorer.reference_table import clear_unfinished, collect, format_markdown, plan_jobs
    from explorer.sweep.execution import run_in_pool

    jobs, cells = plan_jobs(args.out, rows, cols, args.touches, args.seed, calibrations, args.eval_every,
                            args.mesh_resolution, explore_without_normals=not args.refit_only)
    if args.table_only:
        jobs = []
    clear_unfinished(jobs)
    if not args.table_only:
        print(f"reference_table: {len(jobs)} runs to do ({len(cells) - len(jobs)} finished before)", file=sys.stderr)
    failures = []

    def done(outcome) -> None:
        if not outcome.ok:
            failures.append(dict(run=outcome.name, error=outcome.error, traceback=outcome.traceback))
        print(f"  {'ok' if outcome.ok else 'FAILED'} {outcome.name} ({outcome.wall_s:.0f} s)", file=sys.stderr, flush=True)

    try:
        run_in_pool(jobs, args.workers, done)
    finally:
        records = collect(cells, rows, cols, args.mesh_resolution)
        description = (f"Reference table like for like: {len(rows)} rows x {len(cols)} columns, variance strategy, "
                       f"{'no exploration without normals, ' if args.refit_only else ''}"
                       f"{args.touches} touches, seed {args.seed}, mesh resolution {args.mesh_resolution}; "
                       f"calibration: {', '.join(f'{k}: {v}' for k, v in calibrations.items()) or 'none'}.")
        (args.out / "reference_table.md").write_text(format_markdown(records, cols, description))
        (args.out / "reference_table.json").write_text(json.dumps(dict(
            description=description, columns=list(cols), touches=args.touches, seed=args.seed,
            calibrations={k: str(v) for k, v in calibrations.items()}, records=records, failures=failures,
            wall_s=time.perf_counter() - started), indent=2))
    print((args.out / "reference_table.md").read_text())
    return 1 if failures else 0


def existing_calibrations(robots: list[str], args) -> dict[str, Path]:
    """The calibration files already in --out (``--table-only`` runs nothing)."""
    paths = {robot: args.out / "calibration" / f"{robot}-seed{args.seed}" / "joint_calibration.json"
             for robot in robots}
    return {robot: path for robot, path in paths.items() if path.exists()}


def calibrate(robots: list[str], args) -> dict[str, Path]:
    """Each robot's ``joint_calibration.json`` for the run seed (``scripts.calibrate_joints``, in
    parallel subprocesses; a file already there is reused)."""
    out = {}
    processes = []
    for robot in robots:
        directory = args.out / "calibration" / f"{robot}-seed{args.seed}"
        out[robot] = directory / "joint_calibration.json"
        if out[robot].exists():
            continue
        command = [sys.executable, "-m", "scripts.calibrate_joints", "--profile", "hardware-like", "--robot", robot,
                   "--touches", str(args.calibration_touches), "--seed", str(args.seed), "--out", str(directory)]
        log = (args.out / "calibration" / f"{robot}-seed{args.seed}.log")
        log.parent.mkdir(parents=True, exist_ok=True)
        processes.append((robot, subprocess.Popen(command, stdout=log.open("w"), stderr=subprocess.STDOUT)))
    for robot, process in processes:
        if process.wait() != 0 or not out[robot].exists():
            print(f"reference_table: the calibration of {robot} failed (see {args.out / 'calibration'}); its "
                  "calibrated column is left out", file=sys.stderr)
            del out[robot]
    return out


if __name__ == "__main__":
    sys.exit(main())
