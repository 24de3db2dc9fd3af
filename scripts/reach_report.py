"""``python -m scripts.reach_report RUN_DIR ...``: coverage and the out-of-reach breakdown of runs.

One Markdown row per simulated run directory: object, contacts, coverage and the surface fractions
of ``metrics.json``'s ``reach_breakdown`` (``explorer/coverage.py``). A run written before the
breakdown existed gets it computed here from its ``contacts.csv``, the true mesh and the planner
of the run's robot and stand (``--recompute`` does so for every run).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

COLUMNS = ("pad_does_not_fit", "arm_cannot_reach", "hidden_by_stand", "reachable_untouched", "touched")


def breakdown_of(run_dir: Path, metrics: dict, samples: int) -> dict:
    """The run's breakdown, computed afresh (the run's object, robot and seed)."""
    import numpy as np

    import robots
    from explorer.coverage import reach_breakdown
    from explorer.planner import ApproachPlanner
    from explorer.positioner import SimulatedStand, turntable_poses
    from explorer.recording import read_contacts_csv
    from explorer.rig import object_prior
    from robots.ik import PadIK
    from robots.kinematics import ArmKinematics
    from scripts._cli import recorded_object

    truth = recorded_object("reach_report", run_dir, metrics["object"]).mesh
    spec = robots.load(metrics.get("robot", "armar3"))
    kin = ArmKinematics(spec)
    stand = SimulatedStand(lambda position, quat: None, np.asarray(spec.workspace_center_m, float),
                           turntable_poses())
    planner = ApproachPlanner(kin, PadIK(kin), stand, object_prior(truth))
    contacts, _ = read_contacts_csv(run_dir / "contacts.csv")
    return reach_breakdown(truth, contacts, planner, n_samples=samples, seed=int(metrics.get("seed", 0))).as_dict()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m scripts.reach_report", description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path, help="run directories (each with metrics.json)")
    parser.add_argument("--recompute", action="store_true", help="compute the breakdown even if recorded")
    parser.add_argument("--samples", type=int, default=64, help="surface samples when computing (default 64)")
    args = parser.parse_args(argv)
    for run in args.runs:
        if not (run / "metrics.json").is_file():
            parser.error(f"{run} has no metrics.json: give the directories of finished runs")
    print("| object | contacts | coverage | " + " | ".join(c.replace("_", " ") for c in COLUMNS) + " |")
    print("|---" * (3 + len(COLUMNS)) + "|")
    for run in args.runs:
        metrics = json.loads((run / "metrics.json").read_text())
        reach = metrics.get("reach_breakdown")
        if reach is None or args.recompute:
            reach = breakdown_of(run, metrics, args.samples)
        cells = [metrics["object"], str(metrics.get("contacts")), f"{metrics.get('coverage', float('nan')):.2f}"]
        print("| " + " | ".join(cells + [f"{reach[c]:.2f}" for c in COLUMNS]) + " |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
