"""Where a ball calibration holds: its leftover arm error at the configurations an exploration used.

A calibration fitted from ball touches is exact only where its touches were: the offsets it cannot
see drift off elsewhere. This scores ball-touch pose designs where it matters. From recorded runs of
the simulated arm (``--explored RUN_DIR ...``) it takes each contact's true arm configuration (the
recorded joint angles, un-corrected by the run's own calibration, minus the true encoder offsets of
the run's profile and seed) and its measured normal (world frame). Then, for each ``--seeds`` arm of
the hardware-like profile (the seed draws its joint offsets and link lengths) and each design (the
``spread`` default of ``scripts.calibrate_joints``, the ``home`` poses before it; offsets alone or
with the link lengths), it fits the kinematic ball touches of ``calibrate_joints --kinematic``
(first two thirds, the robust fit, as ``calibrate_joints`` saves it) and scores the fit at those
configurations: the signed distance between where the corrected model and the true arm put the
sensor's pivot, along the contact normal (what moves a contact off the surface). Printed per design
as the RMS over contacts and the median (a bias that every contact shares), mean and worst over
the seeds, mm.

    python -m scripts.calibration_poses --explored RUN [RUN ...] --seeds 5,6,7,8,9
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

DESIGNS = (("home", False), ("home", True), ("spread", False), ("spread", True))
"""(poses, fit link lengths) pairs scored, the design before issue 12's change first."""


def explored_configurations(run: Path) -> tuple[str, np.ndarray, np.ndarray]:
    """The robot name, the true joint angles (n, dof) radians at each contact and each contact's
    measured outward normal (n, 3), world frame, of the recorded simulated run ``run``."""
    import robots
    from explorer.session import SessionReader
    from explorer.sim_profile import get_profile

    session = run / "session" if (run / "session").is_dir() else run
    reader = SessionReader(session)
    metadata = reader.metadata
    contacts = reader.contacts()
    states = reader.joint_states()
    if not contacts or len(states.t_s) == 0:
        raise ValueError(f"{run}: no contact with joint states recorded")
    spec = robots.load(metadata["robot"])
    at = np.searchsorted(states.t_s, [c.t_s for c in contacts]).clip(0, len(states.t_s) - 1)
    applied = np.asarray((metadata.get("calibration") or {}).get("offset_rad") or np.zeros(spec.dof), float)
    true_offsets = get_profile(metadata.get("profile") or "datasheet-noise").joint_offsets_rad(spec.dof, int(metadata["seed"]))
    q_true = states.q[at] + applied - true_offsets
    return metadata["robot"], q_true, np.array([c.normal for c in contacts])


def pivot_error_along_normal_m(kinematics, q_true, normals, true_offset_rad, true_lengths_m: dict,
                               fitted_offset_rad, fitted_lengths_m: dict) -> np.ndarray:
    """(n,) signed distance, metres, from the true pivot to where the calibrated model puts it, along
    ``normals`` ((n, 3)): the arm with ``true_offset_rad`` (reading minus true angle) and
    ``true_lengths_m`` at ``q_true`` ((n, dof)), read through its encoders and the fitted model."""
    from robots.link_lengths import link_length_shift_m

    pivot = kinematics.spec.pivot_link
    q_model = q_true + np.asarray(true_offset_rad) - np.asarray(fitted_offset_rad)
    model = kinematics.forward_kinematics(q_model, pivot).position_m
    if fitted_lengths_m:
        model = model + link_length_shift_m(kinematics, q_model, fitted_lengths_m)
    true = kinematics.forward_kinematics(q_true, pivot).position_m
    if true_lengths_m:
        true = true + link_length_shift_m(kinematics, q_true, true_lengths_m)
    return np.sum((model - true) * np.asarray(normals), axis=1)


def score_poses(robot: str, seed: int, spread: bool, q_true, normals) -> dict[bool, tuple[float, float]]:
    """For one arm and pose design, fitted without and with link lengths (the key): (RMS, median)
    of :func:`pivot_error_along_normal_m`, metres. The touches are made once for both fits."""
    from explorer.sim_profile import get_profile
    from robots.joint_calibration import ROBUST_RIDGE_M_PER_RAD, ROBUST_SCALE_M, SphereTouches, fit_joint_offsets
    from scripts.calibrate_joints import BALL_RADIUS_M, kinematic_touches

    q, quats, _, balls, truth, kinematics, true_lengths, _ = kinematic_touches(
        get_profile("hardware-like"), robot, 36, seed, spread=spread)
    first = (2 * len(q)) // 3
    touches = SphereTouches(q[:first], quats[:first], balls[:first], BALL_RADIUS_M)
    scores = {}
    for link_lengths in (False, True):
        fit = fit_joint_offsets(kinematics, touches, ridge_m_per_rad=ROBUST_RIDGE_M_PER_RAD,
                                robust_scale_m=ROBUST_SCALE_M, link_lengths=link_lengths)
        error = pivot_error_along_normal_m(kinematics, q_true, normals, truth, true_lengths, fit.offset_rad,
                                           fit.link_length_error_m)
        scores[link_lengths] = (float(np.sqrt(np.mean(error**2))), float(np.median(error)))
    return scores


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="calibration_poses", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--explored", type=Path, nargs="+", required=True, help="recorded simulated run directories")
    parser.add_argument("--seeds", default="5,6,7,8,9", help="comma-separated arm seeds (default 5-9)")
    parser.add_argument("--json", type=Path, help="also write the figures here")
    args = parser.parse_args(argv)
    try:
        seeds = [int(s) for s in args.seeds.split(",") if s.strip()]
    except ValueError:
        parser.error(f"argument --seeds: comma-separated integers, e.g. 5,6,7, got {args.seeds!r}")
    if not seeds:
        parser.error("argument --seeds: give at least one seed, e.g. 5,6,7")
    for run in args.explored:
        if not (run / "session" / "metadata.json").is_file() and not (run / "metadata.json").is_file():
            parser.error(f"{run}: not a run directory (no session/metadata.json); give the --out of a run")
    pools: dict[str, list] = {}
    for run in args.explored:
        try:
            robot, q_true, normals = explored_configurations(run)
        except ValueError as error:
            parser.error(str(error))
        pools.setdefault(robot, []).append((q_true, normals))
    scored = {}  # (poses, link lengths, robot) -> (seeds, 2) metres
    for robot, parts in sorted(pools.items()):
        q_true, normals = np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])
        for poses in dict(DESIGNS):
            per_seed = [score_poses(robot, seed, poses == "spread", q_true, normals) for seed in seeds]
            for link_lengths in (False, True):
                scored[poses, link_lengths, robot] = (np.array([s[link_lengths] for s in per_seed]), len(q_true))
    results = []
    for poses, link_lengths in DESIGNS:
        for robot in sorted(pools):
            scores, contacts = scored[poses, link_lengths, robot]
            results.append(dict(poses=poses, link_lengths=link_lengths, robot=robot, contacts=contacts,
                                seeds=seeds, rms_mm=(1e3 * scores[:, 0]).round(3).tolist(),
                                median_mm=(1e3 * scores[:, 1]).round(3).tolist()))
    print("| poses | link lengths | robot | contacts | RMS along the normal, mean / worst seed (mm) | "
          "median, mean of abs / worst seed (mm) |")
    print("|---|---|---|---|---|---|")
    for r in results:
        rms, median = np.array(r["rms_mm"]), np.abs(r["median_mm"])
        print(f"| {r['poses']} | {'fitted' if r['link_lengths'] else 'nominal'} | {r['robot']} | {r['contacts']} | "
              f"{rms.mean():.2f} / {rms.max():.2f} | {median.mean():.2f} / {median.max():.2f} |")
    if args.json:
        args.json.write_text(json.dumps(results, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
