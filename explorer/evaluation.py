"""What an exploration or a replay reports against the ground truth, and its JSON form."""
from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

import numpy as np

#: Contacts within this distance of a surface point count as covering it.
COVERAGE_RADIUS_M = 0.01
#: The shape-reconstruction literature's metrics (:class:`reconstruction.metrics.ShapeMetrics`)
#: that ``metrics.json``, the sweep tables and the reference tables carry beside the RMSEs.
STANDARD_METRICS = ("chamfer_l1_mm", "chamfer_l2_mm", "fscore_1mm", "fscore_2mm", "fscore_5mm",
                    "normal_consistency")


def reconstruction_errors(mesh, truth, points: np.ndarray, normals: np.ndarray) -> dict:
    """Surface errors of ``mesh`` against ``truth`` and the contacts' own errors.

    Parameters
    ----------
    mesh, truth : trimesh.Trimesh, object frame, metres
    points, normals : (n, 3) float, contacts in the object frame (outward normals)

    Returns
    -------
    dict
        ``position_rmse_mm``, ``normal_rmse_deg``, ``edge_rmse_mm``, the ``STANDARD_METRICS``
        (Chamfer L1 / L2 mm, F-score at 1 / 2 / 5 mm, normal consistency), ``surface_error`` (all of
        :func:`reconstruction.metrics.surface_error`), and with contacts ``coverage`` (fraction
        of the truth within ``COVERAGE_RADIUS_M`` of a contact), ``contact_normal_error_mean_deg``
        and ``contact_position_error_rms_mm`` (distance of the contacts to the truth).
    """
    from objects.proximity import MeshProximity
    from reconstruction.metrics import contact_coverage, surface_error

    err = surface_error(mesh, truth)
    errors = dict(position_rmse_mm=err.position_rmse_mm, normal_rmse_deg=err.normal_rmse_deg,
                  edge_rmse_mm=err.edge_rmse_mm, **{k: getattr(err, k) for k in STANDARD_METRICS},
                  surface_error=asdict(err))
    if len(points):
        _, distance, face = MeshProximity(truth).query(points)
        cosines = np.clip(np.sum(normals * truth.face_normals[face], axis=1), -1.0, 1.0)
        errors.update(coverage=contact_coverage(points, truth, COVERAGE_RADIUS_M),
                      coverage_radius_m=COVERAGE_RADIUS_M,
                      contact_normal_error_mean_deg=float(np.degrees(np.arccos(cosines)).mean()),
                      contact_position_error_rms_mm=float(1e3 * np.sqrt(np.mean(distance ** 2))))
    return errors


def jsonable(value):
    """JSON-ready copy: numpy arrays and scalars as lists and Python numbers, paths as strings."""
    if isinstance(value, dict):
        return {k: jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    return value
