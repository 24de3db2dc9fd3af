"""Exact closest points on a triangle mesh, vectorised, with certified pruning.

For each query the faces whose centroids are nearest are tried first (k-d tree over centroids). A
face outside the k nearest has its centroid at least d_k away and every point of it within rho_max
(largest centroid-to-corner distance) of its centroid, so it is at least d_k - rho_max away: once
the best distance found is below that bound the answer is exact. Queries not yet certified retry
with k four times larger, up to all faces; a retry evaluates only the new faces whose centroid lies
within (best distance so far + rho_max), the only ones that can be nearer. Cost grows with the number of faces within
(distance + rho_max) of a query: a few dozen for points near a uniformly tessellated surface, all of
them for a point equidistant from a whole patch (the centre of a sphere).
"""
from __future__ import annotations

import numpy as np
import trimesh
from scipy.spatial import cKDTree

FIRST_CANDIDATES = 8
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
        centroids = self._triangles.mean(axis=1)
        self._rho_max = float(np.max(np.linalg.norm(self._triangles - centroids[:, None], axis=2)))
        self._tree = cKDTree(centroids)

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
