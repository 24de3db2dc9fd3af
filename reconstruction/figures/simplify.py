"""Vertex-clustering simplification: fewer faces for 3D plots, without extra dependencies.

Matplotlib draws every polygon of a 3D collection one by one, so a marching-cubes mesh with tens of
thousands of faces is slow to render and no more readable than a few thousand. Snapping vertices to a
grid and merging those that share a cell keeps the shape to within one cell without holes.
"""
from __future__ import annotations

import numpy as np


def cluster_vertices(vertices: np.ndarray, faces: np.ndarray, cell_m: float
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Merge vertices that fall into the same cubic cell; drop faces that collapse.

    Parameters
    ----------
    vertices : (v, 3) float, metres
    faces : (f, 3) int, vertex indices
    cell_m : float
        Cell edge length, metres (> 0).

    Returns
    -------
    vertices : (v', 3) float, the mean of each cell's vertices
    faces : (f', 3) int, faces with three distinct merged vertices, duplicates removed,
        orientation kept
    cluster : (v,) int, the merged vertex each input vertex went to
    """
    if not cell_m > 0:
        raise ValueError(f"cell_m must be > 0 m, got {cell_m}")
    keys = np.floor((vertices - vertices.min(0)) / cell_m).astype(np.int64)
    _, cluster, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    cluster = cluster.ravel()
    merged = np.zeros((len(counts), 3))
    np.add.at(merged, cluster, vertices)
    merged /= counts[:, None]
    new_faces = cluster[faces]
    distinct = ((new_faces[:, 0] != new_faces[:, 1]) & (new_faces[:, 1] != new_faces[:, 2])
                & (new_faces[:, 0] != new_faces[:, 2]))
    new_faces = new_faces[distinct]
    _, first = np.unique(np.sort(new_faces, axis=1), axis=0, return_index=True)
    return merged, new_faces[np.sort(first)], cluster


def simplify_to(vertices: np.ndarray, faces: np.ndarray, max_faces: int
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Coarsen by vertex clustering until at most ``max_faces`` faces remain (unchanged if already).

    The cell grows by 1.25x per try, starting from the mean edge length. Returns the vertices
    (v', 3), faces (f', 3) and, per input vertex, its merged vertex (v,) (see
    :func:`cluster_vertices`).
    """
    if max_faces < 4:
        raise ValueError(f"max_faces must be >= 4, got {max_faces}")
    vertices = np.asarray(vertices, float)
    faces = np.asarray(faces, np.int64)
    if len(faces) <= max_faces:
        return vertices, faces, np.arange(len(vertices))
    edges = vertices[faces] - vertices[np.roll(faces, 1, axis=1)]
    cell = float(np.mean(np.linalg.norm(edges, axis=2)))
    while True:
        merged, merged_faces, cluster = cluster_vertices(vertices, faces, cell)
        if len(merged_faces) <= max_faces:
            return merged, merged_faces, cluster
        cell *= 1.25
