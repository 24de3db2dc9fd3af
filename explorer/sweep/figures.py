"""Error against touches per object: one curve per strategy (and normals setting), spread over seeds.

A run evaluates its reconstruction every few touches (its ``error_curve``), skipping evaluations
before four contacts or where no surface could be meshed; a figure uses the touch counts that every
finished run of that object evaluated, so all its curves share one axis.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Sequence

import numpy as np

MM_TO_M = 1e-3


def error_figures(runs: Sequence[tuple[str, str, bool, list[dict]]], figure_dir: Path) -> list[Path]:
    """Write ``<object>_position_error.png`` and ``<object>_normal_error.png`` for each object.

    Parameters
    ----------
    runs : sequence of (object, strategy, use_normals, error_curve)
        Finished runs; ``error_curve`` as in ``metrics.json`` (touches, position_rmse_mm,
        normal_rmse_deg).
    figure_dir : Path
        Created if missing.

    Returns
    -------
    The PNGs written; objects without a touch count common to all their runs get none.
    """
    from reconstruction.figures import error_vs_touches

    figure_dir = Path(figure_dir)
    by_object: dict[str, list] = {}
    for obj, strategy, use_normals, curve in runs:
        by_object.setdefault(obj, []).append((strategy, use_normals, curve))
    both_settings = len({use_normals for _, _, use_normals, _ in runs}) > 1
    written = []
    for obj, members in by_object.items():
        touches = sorted(set.intersection(*(set(p["touches"] for p in c) for _, _, c in members)))
        if not touches:
            continue
        position: dict[str, list] = {}
        angle: dict[str, list] = {}
        for strategy, use_normals, curve in members:
            label = strategy if not both_settings else (
                f"{strategy}, {'normals' if use_normals else 'no normals'}")
            at = {p["touches"]: p for p in curve}
            position.setdefault(label, []).append([at[n]["position_rmse_mm"] * MM_TO_M for n in touches])
            angle.setdefault(label, []).append([math.radians(at[n]["normal_rmse_deg"]) for n in touches])
        figure_dir.mkdir(parents=True, exist_ok=True)
        written.append(error_vs_touches({k: np.array(v) for k, v in position.items()},
                                        figure_dir / f"{obj}_position_error.png", touches=touches))
        written.append(error_vs_touches({k: np.array(v) for k, v in angle.items()},
                                        figure_dir / f"{obj}_normal_error.png",
                                        ylabel="normal RMSE (deg)", scale=180 / math.pi,
                                        touches=touches))
    return written
