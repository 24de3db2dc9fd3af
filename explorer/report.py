"""Figures of a finished (or interrupted) run, from its output directory alone.

``tactile-report RUN_DIR`` reads ``contacts.csv``, ``reconstruction.ply``, ``metrics.json`` and
``session/`` and writes into ``RUN_DIR/report/`` (or ``--out``):

* ``reconstruction_error.png`` and ``edge_error.png`` - the reconstruction coloured by its distance
  to the ground truth with the contacts, and the truth's sharp edges coloured by their distance to
  the reconstruction (registry objects only);
* ``potential_slice.png`` - the GPIS refitted from ``contacts.csv`` with and without normals, side
  by side, on the slice through the object centre;
* ``sensor_traces.png`` - acceleration, orientation change and drift-compensated pressure around
  the first contacts, with the detected contact intervals shaded;
* ``error_vs_touches.png`` - from the run's error curve.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from explorer.recording import read_contacts_csv

#: Seconds of sensor stream shown in the traces (the first presses of the run).
TRACE_WINDOW_S = 20.0


def write_report(run_dir: Path, out_dir: Path | None = None) -> list[Path]:
    """Write the figures of the run in ``run_dir``; returns the paths written."""
    import trimesh

    import objects
    from explorer.session import read_session
    from reconstruction import figures
    from reconstruction.gpis import GPIS
    from sensor.contact_detection import PressureContactDetector

    run_dir = Path(run_dir)
    if not (run_dir / "contacts.csv").is_file():
        raise FileNotFoundError(f"{run_dir} has no contacts.csv: not an exploration run directory")
    out = Path(out_dir) if out_dir is not None else run_dir / "report"
    out.mkdir(parents=True, exist_ok=True)
    metrics = json.loads((run_dir / "metrics.json").read_text()) if (run_dir / "metrics.json").is_file() else {}
    points, normals = read_contacts_csv(run_dir / "contacts.csv")
    written: list[Path] = []

    truth = None
    name = metrics.get("object")
    if name in objects.names() or objects.generated.is_generated_name(name):
        truth = objects.load(name).mesh
    mesh_path = run_dir / "reconstruction.ply"
    mesh = trimesh.load(mesh_path, force="mesh") if mesh_path.is_file() else None
    if truth is not None and mesh is not None:
        written.append(figures.error_coloured_views(mesh, truth, points, out / "reconstruction_error.png"))
        if len(objects.sharp_edges(truth)):
            written.append(figures.edge_error_view(truth, mesh, out / "edge_error.png"))
    if truth is not None and len(points) >= 1:
        lo, hi = truth.bounds
        pad = 0.25 * float(np.max(hi - lo))
        bounds = (lo - pad, hi + pad)
        with_normals = GPIS(bounds=bounds).fit(points, normals)
        without = GPIS(bounds=bounds, use_normals=False).fit(points)
        written.append(figures.potential_slice(with_normals, without, truth,
                                               offset_m=float(0.5 * (lo[2] + hi[2])),
                                               path=out / "potential_slice.png"))
    curve = metrics.get("error_curve") or []
    if curve:
        errors = np.array([[c["position_rmse_mm"] * 1e-3 for c in curve]])
        written.append(figures.error_vs_touches({metrics.get("strategy", "run"): errors},
                                                out / "error_vs_touches.png",
                                                touches=[c["touches"] for c in curve]))
    session_dir = run_dir / "session"
    if session_dir.is_dir():
        readings = list(read_session(session_dir).readings)
        if readings:
            t0 = readings[0].t_s
            window = [r for r in readings if r.t_s - t0 <= TRACE_WINDOW_S]
            events = PressureContactDetector().process(window)
            written.append(figures.sensor_traces(window, events, out / "sensor_traces.png"))
    return written
