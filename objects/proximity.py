"""Exact closest points on a triangle mesh, vectorised, with certified pruning.

For each query the faces whose centroids are nearest are tried first (k-d tree over centroids). A
face outside the k nearest has its centroid at least d_k away and every point of it within rho_max
(largest centroid-to-corner distance) of its centroid, so it is at least d_k - rho_max away: once
the best distance found is below that bound the answer is exact. Queries not yet certified retry
with k four times larger, up to all faces; a retry evaluates only the new faces whose centroid lies
within (best distance so far + rho_max), the only ones that can be nearer. Cost grows with the number of faces within
(distance + rho_max) of a query: a few dozen for points near a uniformly tessellated surface, all of
them for a point equidistant from a whole patch (the centre of a sphere).

:meth:`MeshProximity.normal_cone_error` measures a normal against the surface at the closest point.
Where that point lies on an edge or a vertex, every normal between the normals of the faces meeting
there is a true normal (the normal cone); measuring against the one face the search happened to
return would charge a pad lying across a box edge with the full dihedral angle.
"""
from __future__ import annotations

import numpy as np
import trimesh
from scipy.optimize import nnls
from scipy.spatial import cKDTree

FIRST_CANDIDATES = 8
#: Faces within this of a closest point span its normal cone (metres for the truth meshes: their
#: promised discretisation error, 0.1 mm).
NORMAL_CONE_TOLERANCE = 1e-4
CHUNK_PAIRS = 2_000_000  # point-triangle pairs evaluated at once (memory bound)


def closest_on_triangles(points: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Closest point on triangle (a, b, c) to each point, row by row.

    Voronoi-region test on the triangle's vertices, edges and face (Ericson, Real-Time Collision
    Detection, 5.1.5). Triangles must have positive area.

    Parameters
    ----------
    points, a, b, c : (n, 3) float

    Returns
    -------
    (n, 3) float
    """
    ab, ac, ap = b - a, c - a, points - a
    bp, cp = points - b, points - c
    d1, d2 = np.einsum("nd,nd->n", ab, ap), np.einsum("nd,nd->n", ac, ap)
    d3, d4 = np.einsum("nd,nd->n", ab, bp), np.einsum("nd,nd->n", ac, bp)
    d5, d6 = np.einsum("nd,nd->n", ab, cp), np.einsum("nd,nd->n", ac, cp)
    vc, vb, va = d1 * d4 - d3 * d2, d5 * d2 - d1 * d6, d3 * d6 - d5 * d4

    with np.errstate(divide="ignore", invalid="ignore"):
        t_ab = d1 / (d1 - d3)
        t_ac = d2 / (d2 - d6)
        t_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        total = va + vb + vc
        v, w = vb / total, vc / total
    regions = [
        (d1 <= 0) & (d2 <= 0),
        (d3 >= 0) & (d4 <= d3),
        (vc <= 0) & (d1 >= 0) & (d3 <= 0),
        (d6 >= 0) & (d5 <= d6),
        (vb <= 0) & (d2 >= 0) & (d6 <= 0),
        (va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0),
    ]
    candidates = [a, b, a + t_ab[:, None] * ab, c, a + t_ac[:, None] * ac, b + t_bc[:, None] * (c - b)]
    result = a + v[:, None] * ab + w[:, None] * ac
    for region, point in zip(reversed(regions), reversed(candidates)):  # first matching region wins
        result = np.where(region[:, None], point, result)
    return result


class MeshProximity:
    """Closest-point queries against one mesh (zero-area faces are ignored).

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Any triangle mesh with at least one face of positive area; need not be watertight.
    """

    def __init__(self, mesh: trimesh.Trimesh):
        triangles = np.asarray(mesh.triangles, float)
        area = np.linalg.norm(np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]), axis=1)
        self._face_ids = np.flatnonzero(area > 0)
        if len(self._face_ids) == 0:
            raise ValueError("mesh has no face of positive area")
        self._triangles = triangles[self._face_ids]
        self._normals = np.asarray(mesh.face_normals, float)[self._face_ids]
        centroids = self._triangles.mean(axis=1)
        self._rho_max = float(np.max(np.linalg.norm(self._triangles - centroids[:, None], axis=2)))
        self._tree = cKDTree(centroids)
        # A point on a shared edge is this close to both faces (float64 rounding), whatever the units.
        self._on_face_tolerance = 1e-9 * float(np.linalg.norm(np.ptp(triangles.reshape(-1, 3), axis=0)))

    def query(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Closest surface point to each query point.

        Parameters
        ----------
        points : (n, 3) float
            Query points, mesh frame and units.

        Returns
        -------
        closest : (n, 3) float
        distance : (n,) float
        face : (n,) int
            Index (into the original mesh's faces) of the triangle holding the closest point.
        """
        points = np.asarray(points, float)
        if points.ndim != 2 or points.shape[1] != 3:
            raise ValueError(f"points must have shape (n, 3), got {points.shape}")
        if not np.all(np.isfinite(points)):
            raise ValueError("points has non-finite coordinates")
        n = len(points)
        closest, distance, face = np.zeros((n, 3)), np.full(n, np.inf), np.zeros(n, dtype=np.int64)
        pending = np.arange(n)
        n_faces, tried, k = len(self._triangles), 0, FIRST_CANDIDATES
        while len(pending):
            k = min(k, n_faces)
            certified = np.zeros(len(pending), dtype=bool)
            chunk = max(1, CHUNK_PAIRS // (k - tried))
            for start in range(0, len(pending), chunk):
                rows = pending[start:start + chunk]
                centre_distance, candidate = self._tree.query(points[rows], k=k)
                centre_distance = centre_distance.reshape(len(rows), k)
                candidate = candidate.reshape(len(rows), k)[:, tried:]  # nearer ones were tried before
                # Only faces that can beat the best so far: centroid nearer than best + rho_max.
                useful = centre_distance[:, tried:] < distance[rows, None] + self._rho_max
                if useful.all():
                    tri = self._triangles[candidate.ravel()]
                    query = np.repeat(points[rows], k - tried, axis=0)
                    on_face = closest_on_triangles(query, tri[:, 0], tri[:, 1], tri[:, 2]).reshape(len(rows), k - tried, 3)
                    gap = np.linalg.norm(on_face - points[rows, None], axis=2)
                else:
                    pair_row, pair_col = np.nonzero(useful)
                    tri = self._triangles[candidate[pair_row, pair_col]]
                    on_face = np.zeros((len(rows), k - tried, 3))
                    on_face[pair_row, pair_col] = closest_on_triangles(points[rows][pair_row], tri[:, 0], tri[:, 1],
                                                                       tri[:, 2])
                    gap = np.full((len(rows), k - tried), np.inf)
                    gap[pair_row, pair_col] = np.linalg.norm(on_face[pair_row, pair_col] - points[rows][pair_row],
                                                             axis=1)
                best = np.argmin(gap, axis=1)
                pick = np.arange(len(rows))
                better = gap[pick, best] < distance[rows]
                improved = rows[better]
                closest[improved] = on_face[pick, best][better]
                distance[improved] = gap[pick, best][better]
                face[improved] = self._face_ids[candidate[pick, best][better]]
                certified[start:start + chunk] = (k == n_faces) | (
                    distance[rows] <= centre_distance[:, -1] - self._rho_max)
            pending = pending[~certified]
            tried, k = k, k * 4
        return closest, distance, face

    def faces_at(self, surface_points: np.ndarray, tolerance: float = 0.0) -> list[np.ndarray]:
        """The faces passing within ``tolerance`` of each surface point.

        With ``tolerance`` 0: the face a point lies inside, the two faces of the edge it lies on, all
        faces of its vertex (up to float64 rounding).

        Parameters
        ----------
        surface_points : (n, 3) float
            Points on the mesh (e.g. ``closest`` of :meth:`query`), mesh frame and units.
        tolerance : float
            Mesh units, >= 0.

        Returns
        -------
        list of n int arrays
            Indices into the original mesh's faces; empty for a point on no face.
        """
        if not (np.isfinite(tolerance) and tolerance >= 0):
            raise ValueError(f"tolerance must be a finite length >= 0, got {tolerance!r}")
        surface_points = np.asarray(surface_points, float).reshape(-1, 3)
        reach = tolerance + self._on_face_tolerance
        return [self._face_ids[self._faces_within(point, reach)[0]] for point in surface_points]

    def _faces_within(self, point: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
        """Faces (indices into the positive-area faces) passing within ``radius`` of one point, and
        their closest points to it, (k,) and (k, 3). A face within ``radius`` has its centroid
        within ``radius + rho_max``."""
        near = np.asarray(self._tree.query_ball_point(point, radius + self._rho_max), dtype=np.int64)
        tri = self._triangles[near]
        on = closest_on_triangles(np.repeat(point[None], len(near), 0), tri[:, 0], tri[:, 1], tri[:, 2])
        within = np.linalg.norm(on - point, axis=1) <= radius
        return near[within], on[within]

    def normal_cone_error(self, points: np.ndarray, normals: np.ndarray,
                          tolerance: float = NORMAL_CONE_TOLERANCE) -> np.ndarray:
        """Angle between each normal and the mesh's normal cone at the point's closest surface point.

        The cone at a surface point is spanned by the normals of the faces passing within
        ``tolerance`` of it (:meth:`faces_at`): one normal inside a face, the arc between two normals
        at an edge, their spherical polygon at a vertex (:func:`angle_to_cone`). Within
        ``tolerance`` of an edge a point counts as on it: whether a contact's closest point lies on
        the edge or a micrometre inside one face is below any mesh's accuracy. Where several surface
        points are equally close (within ``tolerance``: a contact pressed into a corner, half way
        through a wall), the smallest angle over their cones: which of them is "the" closest point
        is as arbitrary there. Away from edges and ties this is the angle to the closest face's normal.

        Parameters
        ----------
        points : (n, 3) float
            Query points (e.g. measured contacts), mesh frame and units.
        normals : (n, 3) float
            Unit normals measured there (outward).
        tolerance : float
            Mesh units; the default is 0.1 mm for a mesh in metres, the discretisation error the
            project's truth meshes promise (``tests/test_objects.py``).

        Returns
        -------
        (n,) float, radians, in [0, pi]
        """
        points = np.asarray(points, float).reshape(-1, 3)
        normals = np.asarray(normals, float).reshape(-1, 3)
        _, distance, _ = self.query(points)
        if len(normals) != len(points):
            raise ValueError(f"got {len(points)} points but {len(normals)} normals")
        reach = tolerance + self._on_face_tolerance
        errors = np.empty(len(points))
        for i, (point, normal) in enumerate(zip(points, normals)):
            _, nearest = self._faces_within(point, distance[i] + reach)  # every (almost) closest point
            errors[i] = min(angle_to_cone(normal, self._normals[self._faces_within(at, reach)[0]])
                            for at in nearest)
        return errors


def angle_to_cone(direction: np.ndarray, generators: np.ndarray) -> float:
    """Angle between a unit vector and the convex cone spanned by unit vectors, radians.

    Zero when ``direction`` is a non-negative combination of ``generators`` (non-negative least
    squares); otherwise the angle to the nearest point of the cone's boundary, which lies on one
    of the great-circle arcs between two generators (or at a generator).

    Parameters
    ----------
    direction : (3,) float, unit
    generators : (k, 3) float, unit, k >= 1
    """
    direction = np.asarray(direction, float).reshape(3)
    generators = np.asarray(generators, float).reshape(-1, 3)
    cosines = np.clip(generators @ direction, -1.0, 1.0)
    best = float(np.arccos(cosines.max()))
    if len(generators) < 2 or best == 0.0:
        return best
    if len(generators) >= 3:
        _, residual = nnls(generators.T, direction)
        if residual < 1e-9:
            return 0.0
    for i in range(len(generators)):
        for j in range(i + 1, len(generators)):
            best = min(best, _angle_to_arc(direction, generators[i], generators[j]))
    return best


def _angle_to_arc(direction: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Angle from a unit vector to the shorter great-circle arc between unit ``a`` and ``b``."""
    axis = np.cross(a, b)
    norm = np.linalg.norm(axis)
    ends = float(np.arccos(np.clip(max(direction @ a, direction @ b), -1.0, 1.0)))
    if norm < 1e-12:
        return ends
    axis /= norm
    in_plane = direction - (direction @ axis) * axis
    length = np.linalg.norm(in_plane)
    if length < 1e-12:
        return ends
    in_plane /= length
    # The foot lies on the arc when it is on a's side of b and on b's side of a.
    if np.cross(a, in_plane) @ axis >= 0 and np.cross(in_plane, b) @ axis >= 0:
        return float(np.arcsin(np.clip(abs(direction @ axis), 0.0, 1.0)))
    return ends
