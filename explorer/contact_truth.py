"""Contact errors against the ground truth, by the local shape under the pad (issue 11).

Offline analysis only (the loop never sees the truth): for each recorded contact, the true closest
surface point gives the position error and the normal cone there the normal error (as
``metrics.json`` computes them), and two measures of the shape under the 18 mm pad say why a contact may be off:

* ``edge_distance_m``: distance from the true closest point to the nearest sharp feature edge of
  the truth (dihedral angle > 30 deg, :attr:`objects.ObjectModel.sharp_edges`);
* ``normal_spread_rad``: the largest angle between the true normal there and the true normals
  within the pad's half width of it (faces turned more than 100 deg away, the far side of a thin
  wall, left out): 0 on a plane, about ``w / r`` on a sphere of radius ``r`` and the full turn on
  an edge or a rim.

``scripts/contact_quality.py`` prints these errors binned by both measures for recorded runs.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Half the width of the 18 mm pad, metres: the neighbourhood the pad rests on.
PAD_HALF_WIDTH_M = 0.009
#: Edge-distance bins (metres) and normal-spread bins (radians) of :func:`binned_errors`.
EDGE_BINS_M = (0.0, 0.003, 0.006, 0.009, 0.015, np.inf)
SPREAD_BINS_RAD = tuple(np.radians([0.0, 10.0, 25.0, 45.0, 70.0, 181.0]))


@dataclass(frozen=True)
class ContactTruth:
    """Per-contact errors and local shape, object frame.

    Attributes
    ----------
    position_error_m : (n,) float
        Distance of each contact to the true surface, metres: to the nearest part of it the pad
        could have pressed on (faces within 90 deg of the measured normal,
        :meth:`objects.proximity.MeshProximity.query_facing`), so a contact measured more than half
        way through a thin wall is charged from the face it was on, not the wall's other side.
    normal_error_rad : (n,) float
        Angle between each measured normal and the true normal cone at the closest point (the
        closest face's normal inside a face, any normal between the faces' normals on an edge:
        :meth:`objects.proximity.MeshProximity.normal_cone_error`), radians.
    edge_distance_m : (n,) float
        Distance of the true closest point to the nearest sharp edge (inf without sharp edges), metres.
    normal_spread_rad : (n,) float
        Largest turn of the true normal within ``PAD_HALF_WIDTH_M`` of the true closest point, radians.
    closest_m : (n, 3) float
        True closest surface points, metres.
    true_normal : (n, 3) float
        True outward normals there (of the closest face).
    offset_m : (n,) float
        ``position_error_m`` signed: positive where a contact lies outside the surface (along the
        closest face's outward normal), metres. A wrong pad compliance shows here as an offset that
        grows with the force.
    """

    position_error_m: np.ndarray
    normal_error_rad: np.ndarray
    edge_distance_m: np.ndarray
    normal_spread_rad: np.ndarray
    closest_m: np.ndarray
    true_normal: np.ndarray
    offset_m: np.ndarray


def contact_truth(points: np.ndarray, normals: np.ndarray, mesh, sharp_edges: np.ndarray,
                  samples: int = 40_000, seed: int = 0) -> ContactTruth:
    """Errors and local shape of contacts on a known mesh.

    Parameters
    ----------
    points, normals : (n, 3) float
        Contacts (surface points, outward unit normals), object frame, metres.
    mesh : trimesh.Trimesh
        The truth, object frame, metres, outward normals.
    sharp_edges : (k, 2, 3) float
        Sharp edges as segments (``ObjectModel.sharp_edges``), metres.
    samples : int
        Area-uniform surface samples used for the normal spread.
    seed : int
        Seed of those samples.
    """
    import trimesh
    from scipy.spatial import cKDTree

    from objects.proximity import MeshProximity

    points = np.asarray(points, float).reshape(-1, 3)
    normals = np.asarray(normals, float).reshape(-1, 3)
    proximity = MeshProximity(mesh)
    closest, distance, face = proximity.query_facing(points, normals)
    true_normal = mesh.face_normals[face]
    sample_points, sample_faces = trimesh.sample.sample_surface_even(mesh, samples, seed=seed)
    sample_normals = mesh.face_normals[sample_faces]
    tree = cKDTree(sample_points)
    spread = np.zeros(len(points))
    for i, near in enumerate(tree.query_ball_point(closest, PAD_HALF_WIDTH_M)):
        if near:
            cosines = sample_normals[near] @ true_normal[i]
            cosines = cosines[cosines > np.cos(np.radians(100.0))]
            spread[i] = float(np.arccos(np.clip(cosines.min(), -1.0, 1.0))) if len(cosines) else 0.0
    outside = np.einsum("ij,ij->i", points - closest, true_normal) >= 0.0
    return ContactTruth(distance, proximity.normal_cone_error(points, normals, facing=True),
                        segment_distance(closest, sharp_edges), spread,
                        closest, true_normal, np.where(outside, distance, -distance))


def segment_distance(points: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """(n,) distance of each of (n, 3) points to the nearest of (k, 2, 3) segments (inf for k = 0)."""
    points = np.asarray(points, float).reshape(-1, 3)
    segments = np.asarray(segments, float).reshape(-1, 2, 3)
    if not len(segments):
        return np.full(len(points), np.inf)
    a, b = segments[:, 0], segments[:, 1]
    ab = b - a
    length2 = np.maximum(np.einsum("kd,kd->k", ab, ab), 1e-18)
    out = np.empty(len(points))
    for i, p in enumerate(points):
        t = np.clip(np.einsum("kd,kd->k", p - a, ab) / length2, 0.0, 1.0)
        out[i] = float(np.min(np.linalg.norm(a + t[:, None] * ab - p, axis=1)))
    return out


def binned_errors(truth: ContactTruth, by: str, flags: np.ndarray | None = None) -> list[dict]:
    """Rows of errors per bin of ``by`` (``"edge"``: edge distance, ``"spread"``: normal spread).

    Each row: ``bin`` (label, mm or deg), ``n``, ``position_rms_mm``, ``normal_mean_deg`` and, with
    ``flags`` ((n,) bool, e.g. the pipeline's doubtful flag), ``flagged`` (the fraction flagged).
    """
    if by == "edge":
        values, edges, scale, unit = truth.edge_distance_m, EDGE_BINS_M, 1e3, "mm"
    elif by == "spread":
        values, edges, scale, unit = truth.normal_spread_rad, SPREAD_BINS_RAD, np.degrees(1.0), "deg"
    else:
        raise ValueError(f"by must be 'edge' or 'spread', got {by!r}")
    rows = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        inside = (values >= lo) & (values < hi)
        label = f"{lo * scale:.0f}-{hi * scale:.0f} {unit}" if np.isfinite(hi) and hi * scale < 180 \
            else f">= {lo * scale:.0f} {unit}"
        row = dict(bin=label, n=int(inside.sum()))
        if inside.any():
            row.update(position_rms_mm=float(1e3 * np.sqrt(np.mean(truth.position_error_m[inside] ** 2))),
                       normal_mean_deg=float(np.degrees(truth.normal_error_rad[inside]).mean()))
            if flags is not None:
                row["flagged"] = float(np.mean(np.asarray(flags, bool)[inside]))
        rows.append(row)
    return rows


def with_true_contacts(records: list, mesh, worse_than_m: float = 0.0, leave_out: bool = False,
                       positions: bool = True, normals: bool = True) -> tuple[list, int]:
    """The recorded touches with every contact more than ``worse_than_m`` off the true surface
    measured without error: what the run's reconstruction would have been given had the pipeline
    measured those contacts exactly (``scripts/contact_error_cost.py``).

    Such a contact becomes its true closest point (on the faces its measured normal could have
    pressed on, :meth:`objects.proximity.MeshProximity.query_facing`) with the outward normal of the face holding it
    (a copy; its target, approach and the rest as recorded, so its swept line now ends at the true
    point); only its position or only its normal with ``normals`` or ``positions`` False; with
    ``leave_out`` it is left out instead, swept line and all. Every other touch is passed on as it is.

    Parameters
    ----------
    records : list of explorer.touch.TouchOutcome
        A run's touches in order (a replay's ``ReplayResult.touches``), object frame.
    mesh : trimesh.Trimesh
        The truth, object frame, metres, outward normals.
    worse_than_m : float
        Contacts farther than this from the true surface are changed, metres (0: every contact).

    Returns
    -------
    (list, int)
        The touches and the number of contacts changed.
    """
    from dataclasses import replace

    from objects.proximity import MeshProximity

    if not worse_than_m >= 0.0:
        raise ValueError(f"worse_than_m must be >= 0 metres, got {worse_than_m!r}")
    contacts = [i for i, r in enumerate(records) if r.kind == "contact"]
    if not contacts:
        return list(records), 0
    points = np.array([records[i].position_m for i in contacts], float)
    measured = [records[i].normal for i in contacts]
    if all(n is not None for n in measured):
        closest, distance, face = MeshProximity(mesh).query_facing(points, np.array(measured, float))
    else:
        closest, distance, face = MeshProximity(mesh).query(points)
    changed = {i: k for k, i in enumerate(contacts) if distance[k] > worse_than_m}
    out = []
    for i, record in enumerate(records):
        if i not in changed:
            out.append(record)
        elif not leave_out:
            k = changed[i]
            out.append(replace(record, position_m=closest[k].copy() if positions else record.position_m,
                               normal=mesh.face_normals[face[k]].copy() if normals else record.normal))
    return out, len(changed)
