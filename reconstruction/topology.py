"""The topology of a surface mesh: parts, handles and open boundaries.

A reconstruction can be close to the truth everywhere and still be the wrong shape: a thin plate
rebuilt with holes through it (the 0-level set sagging in from both faces between contacts), a lid
closed over a bowl, a detached blob. The distances average such faults away; the topology names
them. For every connected part of a triangle mesh, Euler's formula

    V - E + F = chi = 2 - 2 g - b

gives its genus ``g`` (handles: a torus or a mug has one, a plate with two holes through it two)
from its Euler characteristic ``chi`` and its number of boundary loops ``b`` (0 for a closed
surface; a marching-cubes surface cut by its meshing region has some).

The counts come from the mesh's face array (its unique edges, and its parts from trimesh's face
adjacency); nothing here depends on the mesh's units or frame.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np


@dataclass(frozen=True)
class Topology:
    """Topology of a triangle mesh.

    Attributes
    ----------
    components : int
        Connected parts (faces sharing an edge).
    euler_characteristic : int
        ``V - E + F`` over the whole mesh (vertices used by a face only).
    genus : int
        Handles, summed over the parts (0 for spheres and boxes, 1 for a torus or a mug).
    boundary_loops : int
        Closed loops of edges used by one face only (0 for a watertight mesh).
    non_manifold_edges : int
        Edges used by more than two faces; the genus is not defined where there are any
        (``genus`` then counts as if each such edge were split).
    """

    components: int
    euler_characteristic: int
    genus: int
    boundary_loops: int
    non_manifold_edges: int

    def as_dict(self) -> dict:
        return asdict(self)


def _connected_groups(pairs: np.ndarray) -> int:
    """Number of connected groups of the nodes named in ``pairs`` ((k, 2) int graph edges)."""
    if not len(pairs):
        return 0
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    nodes, inverse = np.unique(pairs, return_inverse=True)
    inverse = inverse.reshape(-1, 2)
    graph = coo_matrix((np.ones(len(inverse)), (inverse[:, 0], inverse[:, 1])), shape=(len(nodes), len(nodes)))
    return int(connected_components(graph, directed=False)[0])


def surface_topology(mesh) -> Topology:
    """Parts, Euler characteristic, genus and boundary loops of ``mesh`` (trimesh.Trimesh).

    Raises ValueError for a mesh without faces.
    """
    faces = np.asarray(mesh.faces, dtype=np.int64)
    if not len(faces):
        raise ValueError("the mesh has no faces: its topology is undefined")
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    unique_edges, uses = np.unique(edges, axis=0, return_counts=True)
    vertices = int(len(np.unique(faces)))
    chi = vertices - len(unique_edges) + len(faces)
    loops = _connected_groups(unique_edges[uses == 1])
    # faces sharing an edge are one part; a face sharing none is a part of its own
    adjacency = np.asarray(mesh.face_adjacency, dtype=np.int64).reshape(-1, 2)
    linked = len(np.unique(adjacency))
    components = _connected_groups(adjacency) + (len(faces) - linked)
    # chi = sum over parts of (2 - 2 g_i - b_i)  =>  sum g_i = (2 C - chi - B) / 2
    genus = (2 * components - chi - loops) // 2
    return Topology(components=components, euler_characteristic=int(chi), genus=int(genus),
                    boundary_loops=loops, non_manifold_edges=int(np.count_nonzero(uses > 2)))
