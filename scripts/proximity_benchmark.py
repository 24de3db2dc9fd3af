"""Time exact closest-point queries: ``MeshProximity`` (libigl's AABB tree) against trimesh's.

    python -m scripts.proximity_benchmark [--objects banana,generated:bowl/0] [--points 20000] [--repeats 3]

For each object, two query sets of ``--points`` points: near (surface samples moved 2 mm along a
random direction: what a reconstruction's samples are to the truth) and box (uniform in the object's
box grown by 2 cm: a phantom lid's samples). Each is answered by ``objects.proximity.MeshProximity``
and by ``trimesh.proximity.closest_point`` (a second implementation, the baseline), best of
``--repeats``; prints both times, their ratio and the largest distance disagreement, with the
machine and its load. The disagreement is trimesh's: its candidate search may miss the closest face
and answer a few hundredths of a millimetre too far (``MeshProximity`` is checked against a search
over every face in ``tests/test_objects.py``). Used by BENCHMARKS.md, "Closest points from libigl".
"""
from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

DEFAULT_OBJECTS = "banana,bowl,generated:bowl/0,generated:mug/1000"


def _best_seconds(function, repeats: int):
    best, result = np.inf, None
    for _ in range(repeats):
        start = time.perf_counter()
        result = function()
        best = min(best, time.perf_counter() - start)
    return best, result


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m scripts.proximity_benchmark", description=__doc__.split("\n\n")[0])
    parser.add_argument("--objects", default=DEFAULT_OBJECTS, help=f"comma-separated names (default {DEFAULT_OBJECTS})")
    parser.add_argument("--points", type=int, default=20000, help="query points per set (default 20000)")
    parser.add_argument("--repeats", type=int, default=3, help="timed repeats, the best counts (default 3)")
    args = parser.parse_args(argv)
    if args.points < 1 or args.repeats < 1:
        parser.error("--points and --repeats must be >= 1")

    import trimesh

    import objects
    from objects.proximity import MeshProximity

    print(f"{platform.machine()}, {os.cpu_count()} CPUs, python {platform.python_version()}, "
          f"load {os.getloadavg()[0]:.1f}; {args.points} points per set, best of {args.repeats}")
    rng = np.random.default_rng(0)
    for name in [n.strip() for n in args.objects.split(",") if n.strip()]:
        mesh = objects.load(name).mesh
        directions = rng.normal(size=(args.points, 3))
        near = (trimesh.sample.sample_surface(mesh, args.points, seed=1)[0]
                + 0.002 * directions / np.linalg.norm(directions, axis=1, keepdims=True))
        low, high = mesh.bounds
        box = rng.uniform(low - 0.02, high + 0.02, size=(args.points, 3))
        for label, points in (("near", near), ("box", box)):
            ours_s, (_, ours, _) = _best_seconds(lambda: MeshProximity(mesh).query(points), args.repeats)
            theirs_s, (_, theirs, _) = _best_seconds(lambda: trimesh.proximity.closest_point(mesh, points),
                                                     args.repeats)
            print(f"  {name:22s} {len(mesh.faces):6d} faces  {label:4s}  MeshProximity {ours_s:7.3f} s  "
                  f"trimesh {theirs_s:7.3f} s  ratio {theirs_s / ours_s:6.1f}x  "
                  f"max |distance difference| {np.max(np.abs(ours - theirs)):.1e} m")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
