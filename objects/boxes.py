"""Axis-aligned boxes with sharp edges, each face split into a grid of near-square cells.

A box needs only 12 triangles; the grid keeps triangles small and similar in size across objects,
which suits surface sampling and any consumer that works on mesh vertices.
"""
from __future__ import annotations

import numpy as np
import trimesh


def box_mesh(size_m: np.ndarray, max_spacing_m: float) -> trimesh.Trimesh:
    """Box centred at the origin, sides along x, y, z, outward normals.

    Parameters
    ----------
    size_m : (3,) float
        Side lengths along x, y, z, metres.
    max_spacing_m : float
        Largest grid cell side, metres.
    """
    size_m = np.asarray(size_m, float)
    if size_m.shape != (3,) or np.any(size_m <= 0):
        raise ValueError(f"size_m must be three positive lengths, got {size_m}")
    if max_spacing_m <= 0:
        raise ValueError(f"max_spacing_m must be positive, got {max_spacing_m}")
    ticks = [np.linspace(-s / 2, s / 2, max(1, int(np.ceil(s / max_spacing_m - 1e-9))) + 1) for s in size_m]

    vertices, faces = [], []
    offset = 0
    for axis in range(3):
        u_axis, v_axis = (axis + 1) % 3, (axis + 2) % 3  # e_u x e_v = e_axis
        u, v = np.meshgrid(ticks[u_axis], ticks[v_axis], indexing="ij")
        nu, nv = u.shape
        corner = (np.arange(nu - 1)[:, None] * nv + np.arange(nv - 1)[None, :]).ravel()
        quads = np.column_stack([corner, corner + nv, corner + nv + 1, corner + 1])
        for side in (-1.0, 1.0):
            points = np.empty((u.size, 3))
            points[:, axis] = side * size_m[axis] / 2
            points[:, u_axis], points[:, v_axis] = u.ravel(), v.ravel()
            q = quads if side > 0 else quads[:, ::-1]
            faces.append(np.vstack([q[:, [0, 1, 2]], q[:, [0, 2, 3]]]) + offset)
            vertices.append(points)
            offset += len(points)

    # Grid points on shared edges are bitwise equal (same tick arrays), so exact merging is safe.
    unique, inverse = np.unique(np.vstack(vertices), axis=0, return_inverse=True)
    return trimesh.Trimesh(unique, inverse.reshape(-1)[np.vstack(faces)], process=False)
