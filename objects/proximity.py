"""Exact closest points on a triangle mesh, and normals measured against the surface's normal cone.

:meth:`MeshProximity.query` asks libigl's AABB tree (``igl.AABB.squared_distance``, exact
point-triangle distances with a bounding-volume hierarchy in C++). It replaced a numpy search over
a k-d tree of face centroids written here before: the same distances (to 1e-16 m) 5-60x faster
(BENCHMARKS.md, "Closest points from libigl"), which is most of the time an evaluation takes.

:meth:`MeshProximity.normal_cone_error` measures a normal against the surface at the closest point.
Where that point lies on an edge or a vertex, every normal between the normals of the faces meeting
there is a true normal (the normal cone); measuring against the one face the search happened to
return would charge a pad lying across a box edge with the full dihedral angle.

:meth:`MeshProximity.query_facing` takes the closest point among the faces a pad could have pressed
on (outward normal within 90 deg of the measured one): a contact measured more than half way
through a thin wall is scored from the face it was on, not against the far face's opposite normal.
"""
from __future__ import annotations

import numpy as np
import trimesh
from scipy.optimize import nnls
from scipy.spatial import ConvexHull, QhullError, cKDTree

from common.directions import perpendicular_frame

#: Faces within this of a closest point span its normal cone (metres for the truth meshes: their
#: promised discretisation error, 0.1 mm).
NORMAL_CONE_TOLERANCE = 1e-4


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


def _igl():
    try:
        import igl
    except ImportError as err:  # a hard dependency, but say what is missing
        raise ImportError("objects.proximity needs libigl: pip install libigl") from err
    return igl


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
        self._mesh_normals = np.asarray(mesh.face_normals, float)
        self._normals = self._mesh_normals[self._face_ids]
        centroids = self._triangles.mean(axis=1)
        self._rho_max = float(np.max(np.linalg.norm(self._triangles - centroids[:, None], axis=2)))
        self._tree = cKDTree(centroids)  # for the faces near one point (the normal cone)
        self._vertices = np.ascontiguousarray(mesh.vertices, dtype=np.float64)
        self._faces = np.ascontiguousarray(np.asarray(mesh.faces)[self._face_ids], dtype=np.int64)
        self._aabb = _igl().AABB()
        self._aabb.init(self._vertices, self._faces)
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
            Index (into the original mesh's faces) of a triangle holding the closest point; on an
            edge or a vertex any of the faces meeting there (:meth:`faces_at` gives them all).
        """
        points = np.asarray(points, float)
        if points.ndim != 2 or points.shape[1] != 3:
            raise ValueError(f"points must have shape (n, 3), got {points.shape}")
        if not np.all(np.isfinite(points)):
            raise ValueError("points has non-finite coordinates")
        if len(points) == 0:
            return np.zeros((0, 3)), np.zeros(0), np.zeros(0, dtype=np.int64)
        squared, face, closest = self._aabb.squared_distance(self._vertices, self._faces,
                                                              np.ascontiguousarray(points))
        return closest, np.sqrt(squared), self._face_ids[face]

    def query_facing(self, points: np.ndarray, normals: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Closest point on the faces a pad measuring ``normals`` could have pressed on.

        A pad presses a face from outside, so the face it met has an outward normal within 90 deg
        of the (outward) normal it measured. The plain closest point is that face's unless a
        contact lies more than half way through a thin wall: a contact measured 4 mm inside the
        outer face of a 6 mm wall is 2 mm from the inner face, whose normal is opposite. Here only
        faces with ``face_normal . normal > 0`` count; where no face does, the plain closest point.

        Parameters
        ----------
        points : (n, 3) float
            Query points (measured contacts), mesh frame and units.
        normals : (n, 3) float
            Outward normals measured there (need not be unit length).

        Returns
        -------
        closest, distance, face : as :meth:`query`
        """
        points = np.asarray(points, float).reshape(-1, 3)
        normals = np.asarray(normals, float).reshape(-1, 3)
        if len(normals) != len(points):
            raise ValueError(f"got {len(points)} points but {len(normals)} normals")
        closest, distance, face = self.query(points)
        for i in np.flatnonzero(np.einsum("ij,ij->i", self._mesh_normals[face], normals) <= 0.0):
            facing = np.flatnonzero(self._normals @ normals[i] > 0.0)
            if not len(facing):
                continue
            tri = self._triangles[facing]
            on = closest_on_triangles(np.repeat(points[i][None], len(facing), 0), tri[:, 0], tri[:, 1], tri[:, 2])
            gap = np.linalg.norm(on - points[i], axis=1)
            k = int(np.argmin(gap))
            closest[i], distance[i], face[i] = on[k], gap[k], self._face_ids[facing[k]]
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
                          tolerance: float = NORMAL_CONE_TOLERANCE, facing: bool = False) -> np.ndarray:
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
        facing : bool
            Measure at the closest point of :meth:`query_facing` (the faces the pad could have
            pressed on) instead of the plain closest point.

        Returns
        -------
        (n,) float, radians, in [0, pi]
        """
        points = np.asarray(points, float).reshape(-1, 3)
        normals = np.asarray(normals, float).reshape(-1, 3)
        if len(normals) != len(points):
            raise ValueError(f"got {len(points)} points but {len(normals)} normals")
        _, distance, _ = self.query_facing(points, normals) if facing else self.query(points)
        reach = tolerance + self._on_face_tolerance
        errors = np.empty(len(points))
        for i, (point, normal) in enumerate(zip(points, normals)):
            ids, nearest = self._faces_within(point, distance[i] + reach)  # every (almost) closest point
            if facing:
                facing_ids = self._normals[ids] @ normal > 0.0
                nearest = nearest[facing_ids] if facing_ids.any() else nearest
            # One point per place: at a vertex every face meeting there returns the vertex itself.
            nearest = nearest[np.unique(np.round(nearest / (1e-3 * reach)), axis=0, return_index=True)[1]]
            errors[i] = min(angle_to_cone(normal, self._normals[self._faces_within(at, reach)[0]])
                            for at in nearest)
        return errors


def angle_to_cone(direction: np.ndarray, generators: np.ndarray) -> float:
    """Angle between a unit vector and the convex cone spanned by unit vectors, radians.

    Zero when ``direction`` is a non-negative combination of ``generators`` (non-negative least
    squares); otherwise the angle to the nearest point of the cone's boundary, which lies on one
    of the great-circle arcs between two generators (or at a generator). Up to
    ``PAIRWISE_GENERATORS`` generators every pair's arc is tried; more (the fan of faces at a
    revolved mesh's pole: 384 on a generated bowl's floor, 73 536 pairs) are first cut to the
    cone's boundary (:func:`cone_boundary_pairs`), which gives the same angle.

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
    pairs = cone_boundary_pairs(generators) if len(generators) > PAIRWISE_GENERATORS else _every_pair(len(generators))
    first, second = np.array(pairs).T
    return min(best, float(_angles_to_arcs(direction, generators[first], generators[second]).min()))


#: Above this many generators :func:`angle_to_cone` tries only the cone's boundary arcs.
PAIRWISE_GENERATORS = 8


def cone_boundary_pairs(generators: np.ndarray) -> list[tuple[int, int]]:
    """Pairs of generators whose great-circle arcs make up the boundary of the cone they span.

    Within an open hemisphere the gnomonic projection onto the plane tangent at the generators'
    mean direction maps great circles to straight lines, so the boundary is the projected points'
    convex hull (``scipy.spatial.ConvexHull``), its edges in order; generators on one great
    circle give its two extreme ones. A cone reaching beyond a hemisphere has no such projection:
    every pair is returned.

    Parameters
    ----------
    generators : (k, 3) float, unit
    """
    mean = generators.sum(0)
    if np.linalg.norm(mean) < 1e-12:
        return _every_pair(len(generators))
    mean = mean / np.linalg.norm(mean)
    heights = generators @ mean
    if heights.min() <= 1e-6:
        return _every_pair(len(generators))
    side_1, side_2 = perpendicular_frame(mean[None])
    flat = (generators / heights[:, None]) @ np.column_stack([side_1[0], side_2[0]])   # (k, 2)
    try:
        vertices = ConvexHull(flat).vertices                                     # counter-clockwise
    except QhullError:                                                           # on one line
        along = (flat - flat.mean(0)) @ np.linalg.svd(flat - flat.mean(0))[2][0]
        return [(int(np.argmin(along)), int(np.argmax(along)))]
    return [(int(a), int(b)) for a, b in zip(vertices, np.roll(vertices, -1))]


def _every_pair(count: int) -> list[tuple[int, int]]:
    return [(i, j) for i in range(count) for j in range(i + 1, count)]


def _angles_to_arcs(direction: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle from a unit vector to the shorter great-circle arc between unit ``a[i]`` and ``b[i]``.

    ``a``, ``b`` : (m, 3) float, unit. Returns (m,) float, radians.
    """
    axis = np.cross(a, b)
    norm = np.linalg.norm(axis, axis=1)
    ends = np.arccos(np.clip(np.maximum(a @ direction, b @ direction), -1.0, 1.0))
    axis = axis / np.where(norm < 1e-12, 1.0, norm)[:, None]
    in_plane = direction[None] - (axis @ direction)[:, None] * axis
    length = np.linalg.norm(in_plane, axis=1)
    in_plane = in_plane / np.where(length < 1e-12, 1.0, length)[:, None]
    # The foot lies on the arc when it is on a's side of b and on b's side of a.
    on_arc = ((np.einsum("ij,ij->i", np.cross(a, in_plane), axis) >= 0)
              & (np.einsum("ij,ij->i", np.cross(in_plane, b), axis) >= 0)
              & (norm >= 1e-12) & (length >= 1e-12))
    return np.where(on_arc, np.arcsin(np.clip(np.abs(axis @ direction), 0.0, 1.0)), ends)
