"""``tactile-explore``: a headless simulated exploration of one object (the project's main job).

    tactile-explore --object banana --touches 50 --out results/banana
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path


def main(argv: list[str] | None = None) -> None:
    import objects
    import robots
    from explorer.run import RunSettings, explore
    from explorer.strategies import STRATEGIES

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--object", default="banana",
                        help=f"registry name ({', '.join(objects.names())}) or a mesh file in metres")
    parser.add_argument("--robot", default="armar3", help=f"one of {', '.join(robots.names())}")
    parser.add_argument("--strategy", default="variance", choices=sorted(STRATEGIES))
    parser.add_argument("--touches", type=int, default=50, help="touch budget")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--no-normals", action="store_true", help="classic GPIS without normals")
    parser.add_argument("--out", type=Path, default=Path("results/explore"))
    parser.add_argument("--gui", action="store_true", help="show the PyBullet window")
    args = parser.parse_args(argv)
    if args.touches < 1:
        parser.error("--touches must be at least 1")

    import torch

    # The loop's tensors are small (IK batches, one GP row block): extra intra-op threads only
    # add synchronisation, and on a loaded machine they spin (measured: IK 50x slower).
    torch.set_num_threads(1)
    settings = RunSettings(object=args.object, robot=args.robot, strategy=args.strategy,
                           touches=args.touches, seed=args.seed, use_normals=not args.no_normals,
                           gui=args.gui)
    from tqdm import tqdm

    with tqdm(total=args.touches, unit="touch", desc=f"{args.object}/{args.strategy}") as bar:
        def progress(record):
            bar.update(1)
            bar.set_postfix_str(record.kind)

        result = explore(settings, args.out, progress)
    keys = ("touches", "contacts", "misses", "position_rmse_mm", "normal_rmse_deg", "coverage",
            "reachable_fraction", "wall_time_s", "simulated_time_s")
    print(json.dumps({k: result.metrics.get(k) for k in keys}, indent=2))
    print(f"outputs in {args.out}")


if __name__ == "__main__":
    main()
