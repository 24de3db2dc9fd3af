"""``python -m scripts.face_cut_speed_benchmark``: what the whole-face cut of ``GPIS.mesh`` costs.

Times ``whole_face_planes`` with and without the contacts' hull facets as seeds at 200 / 400 /
1 000 sampled contacts, and ``GPIS.mesh(symmetry=True)`` at 200 contacts (resolution 64) with both,
on three generated shapes (a tray, a wedge, a blob); medians of 3, ratios measured in the same run.
"""
from __future__ import annotations

import argparse
import platform
import sys

SHAPES = ("generated:tray/1000", "generated:wedge/1000", "generated:blob/1000")


def main(argv: list[str] | None = None) -> int:
    argparse.ArgumentParser(prog="python -m scripts.face_cut_speed_benchmark",
                            description=__doc__.splitlines()[0]).parse_args(argv)
    import objects
    import reconstruction.face_planes as face_planes
    from reconstruction.synthetic_contacts import sample_contacts
    from scripts.gpis_faithfulness_benchmark import METHODS, NESTED_POOL, object_bounds
    from scripts.gpis_speed_benchmark import timed

    def median_s(fn) -> float:
        return timed(fn, repeat=3)

    print(f"machine: {platform.processor() or platform.machine()}, python {platform.python_version()}")
    print("| shape | contacts | faces, patch seeds (s) | faces, with hull seeds (s) | mesh without / with hull seeds (s) | ratio |")
    print("|---|---|---|---|---|---|")
    whole = face_planes.whole_face_planes
    for name in SHAPES:
        truth = objects.load(name).mesh
        for n in (200, 400, 1000):
            points, normals, _, _ = sample_contacts(truth, n, seed=100, pool=NESTED_POOL)
            without = median_s(lambda: whole(points, normals, hull_seeds=False))
            with_hull = median_s(lambda: whole(points, normals))
            mesh = "-"
            if n == 200:
                gp = METHODS["symmetry"](object_bounds(truth)).fit(points, normals)
                times = {}
                try:
                    for hull in (False, True):
                        face_planes.whole_face_planes = lambda c, m, h=hull: whole(c, m, hull_seeds=h)
                        times[hull] = median_s(lambda: gp.mesh(resolution=64, symmetry=True))
                finally:
                    face_planes.whole_face_planes = whole
                mesh = f"{times[False]:.2f} / {times[True]:.2f} | {times[True] / times[False]:.2f}"
            else:
                mesh += " | -"
            print(f"| {name} | {n} | {without:.3f} | {with_hull:.3f} | {mesh} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
