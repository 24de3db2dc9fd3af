"""Time ``ApproachPlanner.transfer_path`` between the standoffs of touches on an object.

    python -m scripts.free_path_benchmark [--object cereal_box] [--robot armar6] [--touches 60] [--pairs 400]

Touches at points sampled on the object's surface (approach along the inward normal, stand at yaw
0) are planned; for ordered pairs of their standoffs the free-move path is timed and classed as
straight (the joint line clears the prior box), planned (a route around it) or none (no clear path
known). Prints the count and median / 90th percentile / maximum milliseconds of each class, with the
machine and its load (issue 11: free moves around the object's box).
"""
from __future__ import annotations

import argparse
import itertools
import os
import platform
import time

import numpy as np


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m scripts.free_path_benchmark", description=__doc__.split("\n\n")[0])
    parser.add_argument("--object", default="cereal_box")
    parser.add_argument("--robot", default="armar6")
    parser.add_argument("--touches", type=int, default=60, help="surface points sampled (default 60)")
    parser.add_argument("--pairs", type=int, default=400, help="standoff pairs timed (default 400)")
    args = parser.parse_args(argv)
    if args.touches < 2 or args.pairs < 1:
        parser.error("--touches must be >= 2 and --pairs >= 1")

    import torch
    import trimesh

    from explorer.planner import ApproachPlanner
    from explorer.positioner import StandPose
    from explorer.rig import object_prior
    from explorer.simulation import build_scene
    from explorer.touch import Touch
    from robots.ik import PadIK

    torch.set_num_threads(1)
    with build_scene(args.object, args.robot, seed=0) as scene:
        mesh = scene.object_model.mesh
        planner = ApproachPlanner(scene.kinematics, PadIK(scene.kinematics), scene.stand, object_prior(mesh))
        pose = StandPose(0.0, 0.0)
        scene.stand.move_to(pose)
        points, faces = trimesh.sample.sample_surface(mesh, args.touches, seed=1)
        standoffs = []
        for point, normal in zip(points, mesh.face_normals[faces]):
            plan = planner.plan(Touch(point, -normal), seed_q=planner.rest_q)
            if plan is not None and plan.stand == pose:
                standoffs.append(plan.standoff_q)
        if len(standoffs) < 2:
            parser.error(f"only {len(standoffs)} of {args.touches} touches were reachable at stand yaw 0; give more --touches")
        planner.transfer_path(standoffs[0], standoffs[0])  # builds the sphere model once, untimed
        times = {"straight": [], "planned": [], "none": []}
        for i, j in itertools.islice(itertools.permutations(range(len(standoffs)), 2), args.pairs):
            start = time.perf_counter()
            route = planner.transfer_path(standoffs[i], standoffs[j])
            elapsed_ms = 1e3 * (time.perf_counter() - start)
            times["none" if route is None else "straight" if len(route) == 1 else "planned"].append(elapsed_ms)
    print(f"{args.robot} at {args.object}: {len(standoffs)} standoffs at stand yaw 0, "
          f"{sum(map(len, times.values()))} pairs; {platform.machine()}, {os.cpu_count()} CPUs, "
          f"python {platform.python_version()}, load {os.getloadavg()[0]:.1f}")
    for kind, values in times.items():
        if values:
            print(f"  {kind:8s} n {len(values):4d}  median {np.median(values):6.1f} ms  "
                  f"p90 {np.percentile(values, 90):6.1f} ms  max {max(values):6.1f} ms")
        else:
            print(f"  {kind:8s} n    0")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
