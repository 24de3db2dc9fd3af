"""A sweep over the generated objects per split and family: table, targets and error-vs-touches figure.

    tactile-sweep --objects generated:mug/1000,... --seeds 2 --eval-every 20 --out DIR
    python -m scripts.split_report DIR            # writes DIR/split_report.md and DIR/split_error.png

Reads the sweep's ``sweep.csv`` and each finished run's ``metrics.json`` error curve; tuning and
held-out split side by side (``objects.generated``), against issue 11's targets at the run budget.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    from explorer.sweep.results import read_csv
    from explorer.sweep.splits import family_table, object_results, split_figure, target_summary

    parser = argparse.ArgumentParser(prog="split_report", description=__doc__.splitlines()[0])
    parser.add_argument("sweep_dir", type=Path, help="output directory of tactile-sweep")
    parser.add_argument("--strategy", default=None, help="the strategy to report (needed if the sweep ran several)")
    parser.add_argument("--no-normals", action="store_true", help="report the classic GPIS's rows instead")
    args = parser.parse_args(argv)
    table = args.sweep_dir / "sweep.csv"
    if not table.is_file():
        parser.error(f"{table} not found: give the output directory of a tactile-sweep run")
    rows = read_csv(table)
    try:
        results = object_results(rows, args.strategy, normals=not args.no_normals)
    except ValueError as error:
        parser.error(str(error))
    if not results:
        parser.error(f"{table} has no finished run on a generated object of the tuning or held-out split")
    curves = []
    for row in rows:
        metrics = args.sweep_dir / "runs" / row["run"] / "metrics.json"
        if row["completed"] and metrics.is_file():
            curves.append((row["object"], json.loads(metrics.read_text()).get("error_curve", [])))
    text = f"{target_summary(results)}\n\n{family_table(results)}\n"
    (args.sweep_dir / "split_report.md").write_text(text)
    figure = split_figure(curves, args.sweep_dir / "split_error.png")
    print(text)
    print(f"wrote {args.sweep_dir / 'split_report.md'} and {figure}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
