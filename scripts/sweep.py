"""``tactile-sweep``: benchmark runs over objects x strategies x seeds, in parallel, resumable.

    tactile-sweep --objects sphere,box --strategies random,variance --seeds 5 --touches 50 \
        --workers 2 --out results/sweep [--no-normals-too] [--ray local|ADDRESS]

Finished runs (``runs/<name>/metrics.json`` with ``"completed": true``) are kept: rerun the same
command after an interruption to finish the rest. Outputs: ``sweep.csv``, ``sweep.md``,
``failures.json``, ``figures/``.
"""
from __future__ import annotations

import argparse
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    from explorer.sweep import SweepConfig, run_sweep
    from scripts._cli import check_out_dir, check_ray_address, float_above, int_at_least

    parser = argparse.ArgumentParser(prog="tactile-sweep", description=__doc__.splitlines()[0])
    parser.add_argument("--objects", default="sphere,box",
                        help="comma-separated registry names, generated:FAMILY/SEED names or mesh files")
    parser.add_argument("--units", choices=("m", "cm", "mm", "in"), default="m",
                        help="length unit of the mesh files in --objects (default m)")
    parser.add_argument("--strategies", default="random,variance", help="comma-separated")
    parser.add_argument("--seeds", type=int, default=5, help="number of seeds: S .. S+N-1 (S = --first-seed)")
    parser.add_argument("--first-seed", type=int, default=0, help="first seed (default 0)")
    parser.add_argument("--touches", type=int, default=50, help="touch budget of each run")
    parser.add_argument("--workers", type=int, default=2, help="runs at a time")
    parser.add_argument("--out", type=Path, default=Path("results/sweep"))
    parser.add_argument("--no-normals-too", action="store_true",
                        help="also run every cell with the classic GPIS without normals")
    parser.add_argument("--ray", metavar="ADDRESS",
                        help="run on Ray: 'local' starts a local instance, else a cluster address")
    parser.add_argument("--robot", default="armar3")
    parser.add_argument("--eval-every", type=int, default=5, help="touches between error evaluations")
    parser.add_argument("--mesh-resolution", type=int, default=96)
    parser.add_argument("--profile", default="datasheet-noise",
                        help="simulation profile: ideal, datasheet-noise (default), hardware-like or a .toml file")
    parser.add_argument("--probe-depth", type=float_above(0.0, inclusive=True), metavar="MM",
                        help="how far past its target a touch may probe, mm (default 150; 30 was the old planner)")
    parser.add_argument("--reach-samples", type=int_at_least(0), metavar="N",
                        help="surface samples of each run's reach breakdown (default 64; 0 skips it)")
    args = parser.parse_args(argv)
    if args.seeds < 1:
        parser.error("--seeds must be at least 1")
    if args.first_seed < 0:
        parser.error("--first-seed must be >= 0")
    if args.workers < 1:
        parser.error("--workers must be at least 1")
    for option, value, minimum in (("--touches", args.touches, 1), ("--eval-every", args.eval_every, 0),
                                   ("--mesh-resolution", args.mesh_resolution, 8)):
        if value < minimum:
            parser.error(f"{option} must be at least {minimum}, got {value}")
    check_out_dir(parser, args.out, reusable=True)
    check_ray_address(parser, args.ray)
    try:
        import objects

        names = tuple(objects.in_metres(n, args.units) if objects.is_mesh_file_name(n) else n
                      for n in _names(args.objects))
        config = SweepConfig(objects=names, strategies=_names(args.strategies),
                             seeds=tuple(range(args.first_seed, args.first_seed + args.seeds)),
                             normals=(True, False) if args.no_normals_too else (True,),
                             touches=args.touches, robot=args.robot, eval_every=args.eval_every,
                             mesh_resolution=args.mesh_resolution, profile=args.profile,
                             **({} if args.probe_depth is None else dict(probe_depth_m=args.probe_depth / 1e3)),
                             **({} if args.reach_samples is None else dict(reach_samples=args.reach_samples)))
        report = run_sweep(config, args.out, workers=args.workers, ray_address=args.ray)
    except (ValueError, ImportError, FileNotFoundError) as exc:
        parser.error(str(exc))
    print(report.markdown_path.read_text())
    print(f"{len(report.executed)} runs executed, {len(report.skipped)} already finished, "
          f"{len(report.failures)} failed; outputs in {args.out}")
    return 1 if report.failures else 0


def _names(text: str) -> tuple[str, ...]:
    names = tuple(n.strip() for n in text.split(","))
    if not all(names):
        raise ValueError(f"empty name in {text!r}")
    return names


if __name__ == "__main__":
    raise SystemExit(main())
