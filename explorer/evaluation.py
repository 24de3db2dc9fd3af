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


def reconstruction_errors(mesh, truth, points: np.ndarray, normals: np.ndarray,
                          kept: np.ndarray | None = None) -> dict:
    """Surface errors of ``mesh`` against ``truth`` and the contacts' own errors.

    Parameters
    ----------
    mesh, truth : trimesh.Trimesh, object frame, metres
    points, normals : (n, 3) float, contacts in the object frame (outward normals)
    kept : (n,) bool, optional
        The contacts the reconstruction was fitted to (False: set aside, e.g. a pad-rim standoff);
        None: all of them.

    Returns
    -------
    dict
        ``position_rmse_mm``, ``normal_rmse_deg``, ``edge_rmse_mm``, the ``STANDARD_METRICS``
        (Chamfer L1 / L2 mm, F-score at 1 / 2 / 5 mm, normal consistency), ``surface_error`` (all of
        :func:`reconstruction.metrics.surface_error`), and with contacts ``coverage`` (fraction
        of the truth within ``COVERAGE_RADIUS_M`` of a contact), ``contact_normal_error_mean_deg``
        (angle to the truth's normal cone at the closest point:
        :meth:`objects.proximity.MeshProximity.normal_cone_error`; a normal between the two faces
        of an edge the contact sits on counts as right), ``contact_normal_error_closest_face_mean_deg``
        (the angle to the one closest face's normal, as before 2026-11-26: on an edge it depends on
        which face the search returns) and ``contact_position_error_rms_mm`` (distance of the
        contacts to the truth; ``contact_position_error_rms_kept_mm`` the same over the ``kept``
        contacts, None when none is kept). All four take the closest point among the faces the pad could
        have pressed on, those within 90 deg of the measured normal
        (:meth:`objects.proximity.MeshProximity.query_facing`; since 2026-11-28): a contact
        measured more than half way through a thin wall is not scored against the far face; the
        topology of both (``topology``, ``truth_topology``:
        :class:`reconstruction.topology.Topology`) and what the reconstruction has too many of,
        ``extra_handles`` (holes through thin walls, bridges) and ``extra_components``; ``recess``
        (:class:`reconstruction.metrics.RecessError`: error and coverage in the truth's recesses, the
        insides of cups and bowls, against the rest).
    """
    from objects.proximity import MeshProximity
    from reconstruction.metrics import contact_coverage, recess_error, surface_error
    from reconstruction.topology import surface_topology

    err = surface_error(mesh, truth)
    shape, true_shape = surface_topology(mesh), surface_topology(truth)
    errors = dict(position_rmse_mm=err.position_rmse_mm, normal_rmse_deg=err.normal_rmse_deg,
                  edge_rmse_mm=err.edge_rmse_mm, **{k: getattr(err, k) for k in STANDARD_METRICS},
                  surface_error=asdict(err), topology=shape.as_dict(), truth_topology=true_shape.as_dict(),
                  extra_handles=shape.genus - true_shape.genus,
                  extra_components=shape.components - true_shape.components,
                  recess=asdict(recess_error(mesh, truth, points if len(points) else None, COVERAGE_RADIUS_M)))
    if len(points):
        rms_mm = lambda d: float(1e3 * np.sqrt(np.mean(d ** 2)))  # noqa: E731
        proximity = MeshProximity(truth)
        _, distance, face = proximity.query_facing(points, normals)
        cosines = np.clip(np.sum(normals * truth.face_normals[face], axis=1), -1.0, 1.0)
        errors.update(coverage=contact_coverage(points, truth, COVERAGE_RADIUS_M),
                      coverage_radius_m=COVERAGE_RADIUS_M,
                      contact_normal_error_mean_deg=float(np.degrees(
                          proximity.normal_cone_error(points, normals, facing=True)).mean()),
                      contact_normal_error_closest_face_mean_deg=float(np.degrees(np.arccos(cosines)).mean()),
                      contact_position_error_rms_mm=rms_mm(distance))
        kept = np.ones(len(points), bool) if kept is None else np.asarray(kept, bool)
        if kept.shape != (len(points),):
            raise ValueError(f"kept must be one flag per contact, shape ({len(points)},), got {kept.shape}")
        errors["contact_position_error_rms_kept_mm"] = rms_mm(distance[kept]) if kept.any() else None
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


def top_face_height_error(mesh, truth, inset_m: float = 0.009, spacing_m: float = 0.002) -> dict:
    """How a flat surface is scored when it lies on a table and only its top face is explored.

    The top face is the truth's faces whose outward normal points up (n_z > 0.99), at height
    ``z_top``. Over that face, inset by ``inset_m`` (the pad's radius: the rim itself is an edge,
    not the flat surface), every ``spacing_m`` a vertical ray from above meets the reconstruction's
    highest surface at ``z``; the error there is ``z - z_top``. Where the ray misses the
    reconstruction the error is the distance from the true point to the reconstruction.

    Parameters
    ----------
    mesh, truth : trimesh.Trimesh, object frame (z up), metres

    Returns
    -------
    dict
        ``top_face_rmse_mm`` (RMS of the errors), ``top_face_max_mm`` (largest |error|),
        ``top_face_missed_fraction`` (rays that missed the reconstruction), ``top_face_points``.
    """
    from objects.proximity import MeshProximity

    up = truth.face_normals[:, 2] > 0.99
    if not up.any():
        raise ValueError("the reference has no upward face (n_z > 0.99): no top face to score")
    top = truth.submesh([np.flatnonzero(up)], append=True)
    z_top = float(np.average(top.triangles_center[:, 2], weights=top.area_faces))
    lo, hi = top.bounds[0, :2] + inset_m, top.bounds[1, :2] - inset_m
    xs = np.arange(lo[0], hi[0] + 1e-12, spacing_m)
    ys = np.arange(lo[1], hi[1] + 1e-12, spacing_m)
    grid = np.stack(np.meshgrid(xs, ys, indexing="ij"), -1).reshape(-1, 2)
    points = np.column_stack([grid, np.full(len(grid), z_top)])
    inside = top.ray.intersects_any(points + [0.0, 0.0, 1.0], np.tile([0.0, 0.0, -1.0], (len(points), 1)))
    points = points[inside]
    above = float(mesh.bounds[1, 2] - z_top) + 0.01
    origins = points + [0.0, 0.0, max(above, 0.01)]
    locations, ray_index, _ = mesh.ray.intersects_location(origins, np.tile([0.0, 0.0, -1.0], (len(points), 1)))
    height = np.full(len(points), -np.inf)
    np.maximum.at(height, ray_index, locations[:, 2])
    error = height - z_top
    missed = ~np.isfinite(height)
    if missed.any():
        error[missed] = MeshProximity(mesh).query(points[missed])[1]
    return dict(top_face_rmse_mm=float(1e3 * np.sqrt(np.mean(error ** 2))),
                top_face_max_mm=float(1e3 * np.max(np.abs(error))),
                top_face_missed_fraction=float(missed.mean()), top_face_points=int(len(points)))
