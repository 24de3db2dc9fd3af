"""``tactile-report``: the figures of an exploration run, from its output directory.

    tactile-report results/explore            # writes results/explore/report/*.png
"""
from __future__ import annotations

import argparse
from pathlib import Path


def main(argv: list[str] | None = None) -> None:
    from explorer.report import write_report

    from scripts._cli import check_out_dir

    parser = argparse.ArgumentParser(prog="tactile-report", description=__doc__.splitlines()[0])
    parser.add_argument("run_dir", type=Path, help="output directory of tactile-explore")
    parser.add_argument("--out", type=Path, default=None, help="default: RUN_DIR/report (redrawn if there)")
    args = parser.parse_args(argv)
    if not args.run_dir.is_dir():
        parser.error(f"run directory {args.run_dir} does not exist")
    if args.out is not None:
        check_out_dir(parser, args.out)
    notes: list[str] = []
    try:
        paths = write_report(args.run_dir, args.out, notes)
    except (FileNotFoundError, ValueError) as err:
        parser.error(str(err))
    for path in paths:
        print(f"wrote {path}")
    for note in notes:
        print(f"not drawn: {note}")


if __name__ == "__main__":
    main()
