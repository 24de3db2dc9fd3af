"""How well the ball calibration recovers a simulated arm, and how much it depends on its touches.

For each robot and seed: the physics touches of ``scripts.calibrate_joints`` (hardware-like by
default), then fits of the joint offsets with and without the pad's compression term (each touch's
force), at each ``--scales`` Cauchy scale, on all touches, on the first two thirds (what
``calibrate_joints`` saves) and on ``--subsets`` random draws of two thirds. Each fit is scored by
the pad error its leftover offsets give (true minus fitted) at 200 reachable ball poses none of the
touches used: the mean distance between where the corrected model and the true arm put the pad, mm.
Prints a markdown table and writes ``calibration_benchmark.json`` into ``--out``.

    python -m scripts.calibration_benchmark --robots armar3,armar6 --seeds 0,1,2,3 --out DIR
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

SCORE_POSES = 200


def pad_error_scorer(kinematics, true_offset_rad: np.ndarray, seed: int):
    """A function: fitted offsets (dof,) -> mean pad position error, mm, at :data:`SCORE_POSES` ball poses."""
    from scripts.calibrate_joints import touch_poses

    _, _, poses = touch_poses(kinematics, SCORE_POSES, np.random.default_rng(100 + seed))
    nominal = kinematics.forward_kinematics(poses).position_m

    def score(offset_rad) -> float:
        true_pad = kinematics.forward_kinematics(poses + (true_offset_rad - offset_rad)).position_m
        return float(1e3 * np.linalg.norm(true_pad - nominal, axis=1).mean())

    return score


def benchmark_one(profile, robot: str, seed: int, touches: int, scales, subsets: int) -> dict:
    """Figures of one robot and seed (module docstring)."""
    from robots.joint_calibration import ROBUST_RIDGE_M_PER_RAD, SphereTouches, fit_joint_offsets
    from scripts.calibrate_joints import BALL_RADIUS_M, run_touches

    q, quats, _, balls, truth, kinematics, _, forces = run_touches(profile, robot, touches, seed)
    score = pad_error_scorer(kinematics, truth, seed)
    n = len(q)
    draws = np.random.default_rng(7)
    subset_rows = [np.sort(draws.choice(n, (2 * n) // 3, replace=False)) for _ in range(subsets)]
    result = {"robot": robot, "seed": seed, "touches_used": n, "uncalibrated_mm": score(np.zeros_like(truth)),
              "forces_n": [float(np.min(forces)), float(np.max(forces))], "fits": []}
    for compression in (False, True):
        all_touches = SphereTouches(q, quats, balls, BALL_RADIUS_M, forces if compression else None)
        for scale in scales:
            def fit(rows):
                return fit_joint_offsets(kinematics, all_touches.subset(rows), ridge_m_per_rad=ROBUST_RIDGE_M_PER_RAD,
                                         robust_scale_m=scale)
            first = fit(np.arange((2 * n) // 3))
            drawn = np.array([score(fit(rows).offset_rad) for rows in subset_rows])
            result["fits"].append({
                "compression": compression, "scale_mm": 1e3 * scale,
                "all_mm": score(fit(np.arange(n)).offset_rad), "first_two_thirds_mm": score(first.offset_rad),
                "compliance_mm_per_n": None if first.pad_compliance_m_per_n is None else 1e3 * first.pad_compliance_m_per_n,
                "subsets_median_mm": float(np.median(drawn)), "subsets_p90_mm": float(np.percentile(drawn, 90)),
                "subsets_max_mm": float(drawn.max())})
    return result


def table(results: list[dict]) -> str:
    lines = ["| robot, seed | uncalibrated | fit | scale (mm) | first 2/3 (saved) | all | subsets median / p90 / max | compliance (mm/N) |",
             "|---|---|---|---|---|---|---|---|"]
    for r in results:
        for f in r["fits"]:
            compliance = "-" if f["compliance_mm_per_n"] is None else f"{f['compliance_mm_per_n']:.2f}"
            lines.append(f"| {r['robot']}, {r['seed']} | {r['uncalibrated_mm']:.2f} | "
                         f"{'with compression' if f['compression'] else 'without'} | {f['scale_mm']:.1f} | "
                         f"{f['first_two_thirds_mm']:.2f} | {f['all_mm']:.2f} | {f['subsets_median_mm']:.2f} / "
                         f"{f['subsets_p90_mm']:.2f} / {f['subsets_max_mm']:.2f} | {compliance} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    from scripts._cli import check_out_dir, check_robot, int_at_least

    parser = argparse.ArgumentParser(prog="calibration_benchmark", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--profile", default="hardware-like")
    parser.add_argument("--robots", default="armar3,armar6", help="comma-separated robot names")
    parser.add_argument("--seeds", default="0,1", help="comma-separated seeds")
    parser.add_argument("--touches", type=int_at_least(12), default=36)
    parser.add_argument("--scales", default="0.5,1.0", help="comma-separated Cauchy scales, mm")
    parser.add_argument("--subsets", type=int_at_least(1), default=20, help="random two-thirds draws per fit")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    from explorer.sim_profile import get_profile

    for robot in args.robots.split(","):
        check_robot(parser, robot, "--robots")
    check_out_dir(parser, args.out)
    try:
        profile = get_profile(args.profile)
        seeds = [int(s) for s in args.seeds.split(",")]
        scales = [1e-3 * float(s) for s in args.scales.split(",")]
    except ValueError as error:
        parser.error(str(error))
    if min(scales) <= 0.0:
        parser.error(f"--scales: every Cauchy scale must be positive millimetres, got {args.scales}")
    import torch

    torch.set_num_threads(1)
    results = []
    for robot in args.robots.split(","):
        for seed in seeds:
            print(f"calibration_benchmark: {robot} seed {seed}", file=sys.stderr, flush=True)
            results.append(benchmark_one(profile, robot, seed, args.touches, scales, args.subsets))
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "calibration_benchmark.json").write_text(json.dumps(results, indent=2))
    print(table(results))
    return 0


if __name__ == "__main__":
    sys.exit(main())
