"""Keep only the surface the GPIS is confident about: a principled filter of phantom surface.

The mean's 0-level set is asserted everywhere, also where no contact constrains it: there a smooth
kernel extrapolates (the slab between the two sides of a thin wall runs on past the rim, a sharp
tip rounds into a lobe). The GP says where this happens: its posterior standard deviation of ``f``
(metres near the surface, since ``f`` behaves like a signed distance) grows away from the contacts.
:func:`confident_surface` removes the faces where it exceeds a bound and that lie outside the
contacts' convex hull (large faces between sparse contacts are uncertain too, but not phantom).
Faces near a contact are never removed: touched surface stays, whatever the variance says.
Between sparse contacts on smooth convex shapes it also cuts true surface (BENCHMARKS.md, issue
10): an option for uses where a phantom bulge costs more than a hole.

The result is an open mesh where unconfident parts were cut; use the full ``GPIS.mesh()`` where a
closed surface is needed.
"""
from __future__ import annotations

import numpy as np

#: Default bound on the posterior standard deviation of ``f`` at kept faces, metres; chosen on the
#: generated tuning split (BENCHMARKS.md, issue 10).
DEFAULT_MAX_STD_M = 2.0e-3
#: Faces with a vertex within this distance of a contact are always kept, metres.
DEFAULT_KEEP_NEAR_CONTACT_M = 4.0e-3
#: Vertices at most this far outside the contacts' convex hull are kept whatever their std, metres.
DEFAULT_HULL_MARGIN_M = 2.0e-3


def hull_distance(contacts: np.ndarray, x: np.ndarray) -> np.ndarray:
    """How far (m, 3) points lie outside the convex hull of (n, 3) contacts, metres; <= 0 inside.

    The largest signed distance to the hull's facet planes: exact in front of a facet, a lower
    bound near the hull's edges and corners. Contacts spanning no volume give +inf everywhere.
    """
    from scipy.spatial import ConvexHull, QhullError

    try:
        planes = ConvexHull(contacts).equations  # unit outward normals, offsets
    except (QhullError, ValueError):
        return np.full(len(x), np.inf)
    return np.max(x @ planes[:, :3].T + planes[:, 3], axis=1)


def vertex_std(gpis, vertices: np.ndarray, keep_near_contact_m: float) -> np.ndarray:
    """Posterior standard deviation of ``f`` at mesh vertices; 0 for vertices near a contact.

    Parameters
    ----------
    gpis : reconstruction.gpis.GPIS
        Fitted.
    vertices : (v, 3) float, metres
    keep_near_contact_m : float
        Vertices within this distance of a contact are not evaluated (reported as 0): that saves
        most of the O(v rows^2) cost once the contacts are dense.

    Returns
    -------
    (v,) float64, units of ``f`` (metres near the surface)
    """
    from scipy.spatial import cKDTree

    distance, _ = cKDTree(gpis.contact_points).query(vertices)
    out = np.zeros(len(vertices))
    far = distance > keep_near_contact_m
    if far.any():
        out[far] = np.sqrt(np.maximum(gpis.variance(vertices[far]), 0.0))
    return out


def mean_surface(model, box, resolution: int, max_std_m: float | None = None, refine_steps: int | None = None,
                 faces=None):
    """The 0-level set of ``model.mean`` over ``box`` ((3,), (3,) metres) as a ``trimesh.Trimesh``,
    cut to its confident faces (:func:`confident_surface`) when ``max_std_m`` is given. ``model``:
    a fitted GPIS or PartitionedGPIS (``mean``, ``variance``, ``contact_points``).
    ``refine_steps``: see :func:`reconstruction.meshing.mesh_zero_level` (None: its default).
    ``faces``: a :class:`reconstruction.face_planes.FacePlanes` whose clearance cuts the mean
    (the 0-level set of ``min(mean, clearance)``), or None."""
    from reconstruction.meshing import DEFAULT_REFINE_STEPS, mesh_zero_level

    steps = DEFAULT_REFINE_STEPS if refine_steps is None else refine_steps
    field = model.mean
    if faces is not None and len(faces):
        field = lambda x: np.minimum(model.mean(x), faces.clearance(x))  # noqa: E731
    surface = mesh_zero_level(field, box, resolution, refine_steps=steps)
    return surface if max_std_m is None else confident_surface(model, surface, max_std_m)


def confident_surface(gpis, mesh, max_std_m: float = DEFAULT_MAX_STD_M,
                      keep_near_contact_m: float = DEFAULT_KEEP_NEAR_CONTACT_M,
                      hull_margin_m: float | None = DEFAULT_HULL_MARGIN_M):
    """The faces of ``mesh`` whose vertices are all confident.

    A vertex is confident when its posterior std is <= ``max_std_m``, or it is within
    ``keep_near_contact_m`` of a contact, or (unless ``hull_margin_m`` is None) it lies at most
    ``hull_margin_m`` outside the convex hull of the contacts: smooth surface spanning sparse
    contacts (a large flat face) is uncertain but not phantom; the lobes lie outside the hull.

    Parameters
    ----------
    gpis : reconstruction.gpis.GPIS
        The fitted GPIS whose 0-level set ``mesh`` is.
    mesh : trimesh.Trimesh
        Usually ``gpis.mesh()``; not modified.
    max_std_m : float
        Bound on the posterior standard deviation of ``f``, metres (> 0).
    keep_near_contact_m : float
        Faces with every vertex within this distance of a contact are kept regardless (>= 0).
    hull_margin_m : float or None
        Margin outside the contacts' convex hull within which uncertain vertices are kept (>= 0);
        None cuts by the std alone.

    Returns
    -------
    trimesh.Trimesh
        A copy holding the kept faces (open where faces were cut). If no face would be kept, the
        input is returned unchanged: an empty surface is never better than an uncertain one.
    """
    if not (np.isfinite(max_std_m) and max_std_m > 0):
        raise ValueError(f"max_std_m must be a positive length, got {max_std_m!r}")
    if not (np.isfinite(keep_near_contact_m) and keep_near_contact_m >= 0):
        raise ValueError(f"keep_near_contact_m must be a length >= 0, got {keep_near_contact_m!r}")
    if hull_margin_m is not None and not (np.isfinite(hull_margin_m) and hull_margin_m >= 0):
        raise ValueError(f"hull_margin_m must be None or a length >= 0, got {hull_margin_m!r}")
    vertices = np.asarray(mesh.vertices)
    confident = np.zeros(len(vertices), bool)
    if hull_margin_m is not None:  # cheap; the std is then needed only outside the hull
        confident = hull_distance(gpis.contact_points, vertices) <= hull_margin_m
    rest = ~confident
    confident[rest] = vertex_std(gpis, vertices[rest], keep_near_contact_m) <= max_std_m
    keep = np.all(confident[mesh.faces], axis=1)
    if keep.all() or not keep.any():
        return mesh.copy()
    out = mesh.copy()
    out.update_faces(keep)
    out.remove_unreferenced_vertices()
    return out
