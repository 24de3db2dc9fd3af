"""Sharp feature edges of a triangle mesh: edges whose two faces meet at a large dihedral angle."""
from __future__ import annotations

import numpy as np
import trimesh

SHARP_ANGLE_RAD = np.radians(30.0)


def sharp_edges(mesh: trimesh.Trimesh, min_angle_rad: float = SHARP_ANGLE_RAD) -> np.ndarray:
    """Mesh edges whose adjacent face normals differ by more than ``min_angle_rad``.

    Convex and concave creases both count. Smooth surfaces tessellated finely enough (neighbouring
    normals within 30 degrees) have none.

    Parameters
    ----------
    mesh : trimesh.Trimesh
    min_angle_rad : float
        Threshold on the angle between the two face normals, radians.

    Returns
    -------
    (k, 2, 3) float
        Edge end points in the mesh's frame and units, sorted by vertex index for a stable order.
    """
    if not 0.0 <= min_angle_rad < np.pi:
        raise ValueError(f"min_angle_rad must lie in [0, pi), got {min_angle_rad}")
    if len(mesh.faces) == 0:
        return np.zeros((0, 2, 3))
    edges = np.sort(mesh.face_adjacency_edges[mesh.face_adjacency_angles > min_angle_rad], axis=1)
    edges = edges[np.lexsort((edges[:, 1], edges[:, 0]))]
    return np.asarray(mesh.vertices, float)[edges].reshape(-1, 2, 3)
