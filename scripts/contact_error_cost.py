"""``python -m scripts.contact_error_cost RUN_DIR [RUN_DIR ...]``: how much of a simulated run's
reconstruction error its contacts' measurement errors cause (issues 10 and 11).

Each run is replayed with its recorded settings and refitted six ways
(:meth:`explorer.replay.SessionReplay.refit`, meshed at the run's resolution, position RMSE as
``metrics.json`` computes it):

* ``recorded``: the contacts as the pipeline measured them and the run's reconstruction took them
  (with its bridged contacts moved in; the run's own RMSE);
* ``exact_bad``: the contacts more than ``--worse-than`` MM (default 3) off the true surface
  replaced by their true closest point and normal (:func:`explorer.contact_truth.with_true_contacts`);
* ``left_out``: those contacts left out;
* ``exact_positions``: every contact at its true closest point, with its measured normal;
* ``exact_normals``: every contact where it was measured, with the true normal there;
* ``exact_all``: every contact at its true closest point with its true normal.

``recorded`` minus ``exact_all`` is what the contacts' errors cost, and the two between say how much
of it is the positions' and how much the normals'; what ``exact_all`` leaves is the exploration's
and the reconstruction's (where the contacts are and how the GPIS joins them). A large
``exact_bad`` gain with few contacts changed says a handful of far-off contacts carry the error; a
``left_out`` no better than ``recorded`` says the reconstruction needs them, flawed as they are.
Simulated runs of a known object only (the truth is the run's object). Prints a markdown table;
``--json FILE`` writes the figures.
"""
from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

#: The refits, in the table's order (module docstring).
VARIANTS = ("recorded", "exact_bad", "left_out", "exact_positions", "exact_normals", "exact_all")


def parse_args(argv=None):
    parser = argparse.ArgumentParser(prog="python -m scripts.contact_error_cost",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", nargs="+", type=Path, help="run directories (each with session/)")
    parser.add_argument("--worse-than", type=float, default=3.0, metavar="MM",
                        help="contacts farther than this from the true surface count as bad (mm, default 3)")
    parser.add_argument("--mesh-resolution", type=int, default=None,
                        help="grid cells per axis to mesh at (default: the run's)")
    parser.add_argument("--json", type=Path, help="write the figures here")
    args = parser.parse_args(argv)
    if not args.worse_than > 0.0:
        parser.error(f"--worse-than must be positive millimetres, got {args.worse_than:g}; e.g. --worse-than 3")
    if args.mesh_resolution is not None and args.mesh_resolution < 8:
        parser.error(f"--mesh-resolution must be at least 8, got {args.mesh_resolution}")
    for run in args.runs:
        if not (run / "session" / "metadata.json").is_file():
            parser.error(f"{run}: not a run directory (no session/metadata.json); give the --out of a run")
    return args


def error_cost(run: Path, worse_than_m: float, mesh_resolution: int | None = None) -> dict:
    """The refits' position RMSE (mm, None where the field had no surface) of one run, with its
    object, contact count and the number of contacts worse than ``worse_than_m``."""
    from explorer.contact_truth import with_true_contacts
    from explorer.replay import ReplaySettings, SessionReplay
    from reconstruction.metrics import surface_error

    replay = SessionReplay(run / "session")
    if replay.truth is None:
        raise ValueError(f"{run}: the run's object {replay.metadata.get('object')!r} has no known truth "
                         "(a simulated run of a registry or generated object or of a mesh file that loads is "
                         f"needed){': ' + replay.truth_note if replay.truth_note else ''}")
    settings = ReplaySettings(figures=False, mesh_resolution=mesh_resolution)
    replayed = replay.run(settings).touches
    resolution = replay.mesh_resolution(settings)
    # the contacts as the run's reconstruction took them (bridged ones moved in, indented ones out), then
    # no further change: an exact contact is not to be moved
    touches = replay.loop_config.reconstruction_records(replayed, replay.pad, replay.use_normals(settings))[0]
    as_given = replace(settings, bridge_concave_contacts=False, indent_convex_contacts=False)

    def rmse(records) -> float | None:
        try:
            mesh = replay.refit(records, as_given).mesh(resolution=resolution,
                                                        refine_steps=replay.loop_config.reconstruction_refine_steps)
        except ValueError:  # no zero level set in the region
            return None
        return float(surface_error(mesh, replay.truth).position_rmse_mm)

    bad, changed = with_true_contacts(touches, replay.truth, worse_than_m)
    left_out, _ = with_true_contacts(touches, replay.truth, worse_than_m, leave_out=True)
    positions, _ = with_true_contacts(touches, replay.truth, normals=False)
    normals, _ = with_true_contacts(touches, replay.truth, positions=False)
    exact, _ = with_true_contacts(touches, replay.truth)
    figures = dict(recorded=rmse(touches), exact_bad=rmse(bad), left_out=rmse(left_out),
                   exact_positions=rmse(positions), exact_normals=rmse(normals), exact_all=rmse(exact))
    return dict(run=str(run), object=str(replay.metadata.get("object")),
                contacts=sum(t.kind == "contact" for t in touches), bad_contacts=changed, rmse_mm=figures)


def _cell(value: float | None) -> str:
    return "-" if value is None else f"{value:.3f}"


def main(argv=None) -> int:
    args = parse_args(argv)
    rows = []
    print(f"| run | object | contacts | worse than {args.worse_than:g} mm | RMSE mm: recorded | bad ones exact | "
          "bad ones left out | positions exact | normals exact | both exact |\n|---|---|---|---|---|---|---|---|---|---|")
    for run in args.runs:
        try:
            row = error_cost(run, 1e-3 * args.worse_than, args.mesh_resolution)
        except ValueError as error:
            print(f"contact_error_cost: {error}", file=sys.stderr)
            return 2
        rows.append(row)
        print(f"| {run.name} | {row['object']} | {row['contacts']} | {row['bad_contacts']} | "
              + " | ".join(_cell(row["rmse_mm"][v]) for v in VARIANTS) + " |")
    means = {}
    for variant in VARIANTS:
        values = [r["rmse_mm"][variant] for r in rows]
        means[variant] = None if any(v is None for v in values) else float(np.mean(values))
    print(f"\nmean of {len(rows)} runs: " + ", ".join(f"{v} {_cell(means[v])} mm" for v in VARIANTS))
    if args.json:
        args.json.write_text(json.dumps(dict(worse_than_mm=args.worse_than, runs=rows, mean_rmse_mm=means), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
