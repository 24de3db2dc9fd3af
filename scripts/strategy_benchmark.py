"""Touches to reach 3 mm and 2 mm per shape and strategy, with a ray-cast probe instead of the robot.

    python -m scripts.strategy_benchmark --objects box,sphere,generated:mug/0 \
        --strategies variance,efficient --touches 60 --eval-every 2 --seeds 0 --out DIR

Each touch of a strategy's first proposal is a ray from ``standoff`` before its target along its
approach, to ``depth`` beyond it (the planner's defaults): the first hit on the true mesh is the
contact, with the sampled-contact noise of :mod:`reconstruction.synthetic_contacts` (0.2 mm along the
normal, 1 mm across, 7 deg mean normal error); a ray that hits nothing is a miss and its points are
free space, as in the loop (:class:`explorer.evidence.SurfaceEvidence`). No arm, stand, pad or
reachability: this measures the information a strategy gains per touch, in seconds of CPU, where a
whole-pipeline sweep (``tactile-sweep --eval-every 1``) takes minutes per run. Writes ``curves.json``
(every run's error curve) and ``table.md`` (position RMSE at the budget, touches to 3 / 2 mm).
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np


def probe_run(name: str, strategy_name: str, touches: int, eval_every: int, seed: int,
              use_normals: bool = True) -> list[dict]:
    """One run's error curve: [{touches, contacts, position_rmse_mm}], evaluated every ``eval_every``."""
    import objects
    from explorer.evidence import SurfaceEvidence
    from explorer.loop import LoopConfig
    from explorer.planner import PlannerConfig, approach_line
    from explorer.rig import object_prior
    from explorer.strategies import ExplorationState, make_strategy
    from reconstruction.gpis import GPIS
    from reconstruction.metrics import surface_error
    from reconstruction.synthetic_contacts import ContactNoise, perturb_normals

    truth = objects.load(name).mesh
    prior = object_prior(truth)
    gp = GPIS(bounds=prior.bounds(), use_normals=use_normals)
    loop_cfg, plan_cfg = LoopConfig(), PlannerConfig()
    evidence = SurfaceEvidence(gp, loop_cfg.free_space_value, loop_cfg.free_space_noise)
    strategy = make_strategy(strategy_name, seed)
    state = ExplorationState(prior)
    noise = ContactNoise()
    rng = np.random.default_rng(seed)
    curve = []
    for n in range(1, touches + 1):
        state.gpis = gp if gp.n_contacts else None
        proposals = strategy.propose(state, 1)
        state.touches += 1
        if not proposals:
            continue
        touch = proposals[0]
        strategy.accepted(touch)
        state.tried_m.append(touch.target_m)
        line = approach_line(touch.target_m, touch.approach_dir, plan_cfg, touch.depth_m)
        start, length = line[0], float(np.linalg.norm(line[-1] - line[0]))
        hits, _, faces = truth.ray.intersects_location(start[None], touch.approach_dir[None])
        along = (hits - start) @ touch.approach_dir if len(hits) else np.zeros(0)
        if len(hits) and along.min() <= length:
            i = int(np.argmin(along))
            normal = truth.face_normals[faces[i]]
            tangent = np.linalg.svd(normal[None])[2][1:]
            point = (hits[i] + normal * rng.normal(scale=noise.normal_std_m)
                     + tangent.T @ rng.normal(scale=noise.tangent_std_m, size=2))
            measured = perturb_normals(normal[None], noise.normal_error_mean_deg, rng)[0]
            if np.all(point >= gp.bounds[0]) and np.all(point <= gp.bounds[1]):
                evidence.add_contact(point, measured)
        elif gp.n_contacts:
            evidence.add_free_space(evidence.inside_bounds(line))
        if eval_every and n % eval_every == 0 and gp.n_contacts >= 4:
            try:
                err = surface_error(gp.mesh(resolution=48), truth, n_samples=5000, sharp_edges=np.zeros((0, 2, 3)))
            except ValueError:
                continue
            curve.append(dict(touches=n, contacts=gp.n_contacts, position_rmse_mm=err.position_rmse_mm))
    return curve


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="strategy-benchmark", description=__doc__.splitlines()[0])
    parser.add_argument("--objects", required=True, help="comma-separated registry or generated:FAMILY/SEED names, "
                        "or 'tuning' / 'held-out' for the generated splits")
    parser.add_argument("--strategies", default="variance,efficient")
    parser.add_argument("--touches", type=int, default=60)
    parser.add_argument("--eval-every", type=int, default=2)
    parser.add_argument("--seeds", type=int, default=1, help="seeds 0 .. N-1")
    parser.add_argument("--no-normals", action="store_true", help="classic GPIS without normals")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    for option, value in (("--touches", args.touches), ("--eval-every", args.eval_every), ("--seeds", args.seeds)):
        if value < 1:
            parser.error(f"{option} must be at least 1, got {value}")
    import objects.generated as generated
    from explorer.strategies import STRATEGIES
    from explorer.sweep.results import SECOND_TARGET_RMSE_MM, TARGET_RMSE_MM, touches_to_reach

    names = []
    for item in args.objects.split(","):
        names += {"tuning": list(generated.TUNING), "held-out": list(generated.HELD_OUT)}.get(item, [item])
    strategies = args.strategies.split(",")
    for s in strategies:
        if s not in STRATEGIES:
            parser.error(f"unknown strategy {s!r}; choose from {', '.join(STRATEGIES)}")
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "curves.json"
    results = json.loads(path.read_text()) if path.exists() else {}
    for name in names:
        for s in strategies:
            for seed in range(args.seeds):
                key = f"{name}|{s}|{seed}|{'no-normals' if args.no_normals else 'normals'}"
                if key in results:
                    continue
                t0 = time.perf_counter()
                curve = probe_run(name, s, args.touches, args.eval_every, seed, not args.no_normals)
                results[key] = dict(curve=curve, wall_s=time.perf_counter() - t0)
                path.write_text(json.dumps(results, indent=1))
                print(key, f"{curve[-1]['position_rmse_mm'] if curve else float('nan'):.2f} mm",
                      f"{time.perf_counter() - t0:.0f} s", flush=True)
    lines = [f"Ray-cast probe, {args.touches} touches, error every {args.eval_every}; mean over seeds.", "",
             "| object | strategy | normals | RMSE at budget (mm) | touches to 3 mm | touches to 2 mm |",
             "|---|---|---|---|---|---|"]
    for name in names:
        for s in strategies:
            runs = [v for k, v in results.items() if k.startswith(f"{name}|{s}|")]
            final = [r["curve"][-1]["position_rmse_mm"] for r in runs if r["curve"]]
            cells = []
            for target in (TARGET_RMSE_MM, SECOND_TARGET_RMSE_MM):
                reached = [touches_to_reach(r["curve"], target) for r in runs]
                got = [x for x in reached if x is not None]
                cells.append(f"{np.mean(got):.0f} ({len(got)}/{len(runs)})" if got else f"- (0/{len(runs)})")
            lines.append(f"| {name} | {s} | {'no' if args.no_normals else 'yes'} | "
                         f"{np.mean(final) if final else float('nan'):.2f} | {cells[0]} | {cells[1]} |")
    (args.out / "table.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
