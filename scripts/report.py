"""``tactile-report``: the figures of an exploration run, from its output directory.

    tactile-report results/explore            # writes results/explore/report/*.png
"""
from __future__ import annotations

import argparse
from pathlib import Path


def main(argv: list[str] | None = None) -> None:
    from explorer.report import write_report

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run_dir", type=Path, help="output directory of tactile-explore")
    parser.add_argument("--out", type=Path, default=None, help="default: RUN_DIR/report")
    args = parser.parse_args(argv)
    try:
        paths = write_report(args.run_dir, args.out)
    except FileNotFoundError as err:
        parser.error(str(err))
    for path in paths:
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
