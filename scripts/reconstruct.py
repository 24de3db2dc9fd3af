"""``tactile-reconstruct``: replay a recorded session with new detector thresholds and GPIS settings.

    tactile-reconstruct results/explore/session --out results/replay --start-threshold-pa 150
    tactile-reconstruct results/teleop --out results/teleop-replay --no-normals
    tactile-reconstruct results/explore --rerun explore.rrd                 # look at it in Rerun

Autonomous and teleop sessions alike (explorer/replay.py says how each is detected again).
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path


def main(argv: list[str] | None = None) -> None:
    from explorer.rerun_view import add_rerun_argument, observer_from_argument
    from reconstruction.gpis import KERNEL_NAMES
    from scripts._cli import check_out_dir, float_above, int_at_least

    parser = argparse.ArgumentParser(prog="tactile-reconstruct", description=__doc__.splitlines()[0])
    parser.add_argument("session", type=Path, help="a session directory (or the run directory holding it)")
    parser.add_argument("--out", type=Path,
                        help="output directory, new or empty (a recorded run is never overwritten); needed "
                             "unless --rerun is given")
    parser.add_argument("--kernel", default="thin_plate", choices=KERNEL_NAMES)
    parser.add_argument("--noise", type=float_above(0.0), help="GPIS value noise, metres")
    parser.add_argument("--normal-noise", type=float_above(0.0), help="GPIS normal noise (per gradient component)")
    parser.add_argument("--no-normals", action="store_true", help="classic GPIS without normals")
    parser.add_argument("--start-threshold-pa", type=float_above(0.0),
                        help="contact start threshold, Pa above baseline")
    parser.add_argument("--end-threshold-pa", type=float_above(0.0), help="contact end threshold, Pa above baseline")
    parser.add_argument("--resolution", type=int_at_least(8), help="mesh grid samples along the longest side")
    parser.add_argument("--side-presses", choices=("on", "off"),
                        help="a GPIS value row where the pad met the surface with its side (no normal); "
                             "default: as recorded")
    parser.add_argument("--bridge-concave", choices=("on", "off"),
                        help="move contacts on concave surfaces in by the height the flat pad bridged "
                             "(LoopConfig.bridge_concave_contacts); default: as recorded")
    parser.add_argument("--indent-convex", choices=("on", "off"),
                        help="move contacts on surfaces curving away in every direction out by what the pad sank "
                             "further on one point (LoopConfig.indent_convex_contacts); default: as recorded")
    parser.add_argument("--point-compliance", type=float_above(0.0), metavar="MM_PER_N",
                        help="the pad's compression on one point to indent with, mm per newton (sessions "
                             "recorded before 2026-12-08 have none); default: as recorded")
    parser.add_argument("--symmetry", choices=("on", "off"),
                        help="mesh with the contacts' images under the mirror planes or axis of revolution they "
                             "support (LoopConfig.reconstruction_symmetry); default: as recorded")
    add_rerun_argument(parser)
    args = parser.parse_args(argv)
    if not args.session.is_dir():
        parser.error(f"session directory {args.session} does not exist")
    if args.out is None and args.rerun is None:
        parser.error("give --out DIR (replay outputs), --rerun [FILE.rrd] (the session in Rerun), or both")
    if args.out is not None:
        check_out_dir(parser, args.out)
    observer = observer_from_argument(parser, args.rerun, "tactile-reconstruct")

    import torch

    from explorer.replay import ReplaySettings, replay

    torch.set_num_threads(1)  # small tensors: extra threads only add synchronisation
    if observer is not None:
        from explorer.rerun_view import log_session

        try:
            touches = log_session(args.session, observer, use_normals=False if args.no_normals else None)
        except ValueError as err:
            parser.error(str(err))
        print(f"logged {touches} touches to " + (args.rerun or "the Rerun viewer"))
    if args.out is None:
        return
    try:
        settings = ReplaySettings(
            start_threshold_pa=args.start_threshold_pa, end_threshold_pa=args.end_threshold_pa,
            kernel=args.kernel, noise=args.noise, normal_noise=args.normal_noise,
            use_normals=False if args.no_normals else None, mesh_resolution=args.resolution,
            side_presses=None if args.side_presses is None else args.side_presses == "on",
            bridge_concave_contacts=None if args.bridge_concave is None else args.bridge_concave == "on",
            indent_convex_contacts=None if args.indent_convex is None else args.indent_convex == "on",
            point_compliance_m_per_n=None if args.point_compliance is None else args.point_compliance * 1e-3,
            reconstruction_symmetry=None if args.symmetry is None else args.symmetry == "on")
        result = replay(args.session, settings, args.out)
    except (ValueError, FileNotFoundError) as err:  # a bad setting, or a session that cannot be replayed
        parser.error(str(err))
    keys = ("touches", "contacts", "misses", "realign", "no_normal", "same_press", "recorded_contacts",
            "indented_contacts", "reconstruction_symmetry", "position_rmse_mm", "normal_rmse_deg", "notes")
    print(json.dumps({k: result.metrics.get(k) for k in keys}, indent=2))
    print(f"outputs in {args.out}")


if __name__ == "__main__":
    main()
