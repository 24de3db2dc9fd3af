"""Score explored flat surfaces as a real one is measured: its top face, lying on a table.

    python -m scripts.top_face_score RUN_DIR [RUN_DIR ...]

For each run (a ``tactile-explore`` output, or a sweep's ``runs/<name>``) prints the whole-surface
position RMSE of ``metrics.json`` beside the top-face height error of ``reconstruction.ply``
(:func:`explorer.evaluation.top_face_height_error`), both in mm.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="top-face-score", description=__doc__.splitlines()[0])
    parser.add_argument("runs", type=Path, nargs="+", help="run directories (metrics.json, reconstruction.ply)")
    parser.add_argument("--inset-mm", type=float, default=9.0, help="margin left out along the rim (default 9, the pad radius)")
    args = parser.parse_args(argv)
    for run in args.runs:
        for name in ("metrics.json", "reconstruction.ply"):
            if not (run / name).is_file():
                parser.error(f"{run} has no {name}: give the output directory of a finished run")
    import trimesh

    from explorer.evaluation import top_face_height_error
    from scripts._cli import recorded_object

    print("| run | object | normals | touches | position RMSE (mm) | top-face RMSE (mm) | top-face max (mm) | rays missed |")
    print("|---|---|---|---|---|---|---|---|")
    for run in args.runs:
        metrics = json.loads((run / "metrics.json").read_text())
        truth = recorded_object("top-face-score", run, metrics["object"]).mesh
        mesh = trimesh.load(run / "reconstruction.ply", force="mesh")
        try:
            top = top_face_height_error(mesh, truth, inset_m=1e-3 * args.inset_mm)
        except ValueError as exc:
            parser.error(f"{run}: {exc}")
        print(f"| {run.name} | {metrics['object']} | {'yes' if metrics.get('use_normals', True) else 'no'} "
              f"| {metrics['touches']} | {metrics.get('position_rmse_mm', float('nan')):.2f} "
              f"| {top['top_face_rmse_mm']:.2f} | {top['top_face_max_mm']:.2f} "
              f"| {top['top_face_missed_fraction']:.3f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
