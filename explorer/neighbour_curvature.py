"""The surface's curvature along the lines from a contact to its neighbours, from measured normals.

For contacts ``i`` and ``j`` on the same side of a surface, ``kappa_ij = (n_j - n_i) . (p_j - p_i) /
|p_j - p_i|^2`` is the normal curvature along the line between them (positive where the normals
diverge: convex; a sphere of radius R gives 1 / R). The pad's corrections read it here: the
bridging over hollows (:mod:`explorer.pad_bridging`) and the deeper indentation on ball-like
surfaces (:mod:`explorer.pad_indentation`).
"""
from __future__ import annotations

from typing import Iterator

import numpy as np
from scipy.spatial import cKDTree

#: Neighbours nearer than this, metres, say nothing of the curvature (their normals' noise over a
#: millimetre reads as any curvature).
MIN_GAP_M = 1e-3


def neighbour_curvatures(points: np.ndarray, normals: np.ndarray, radius_m: float, same_side_cosine: float
                         ) -> Iterator[tuple[int, np.ndarray, np.ndarray]]:
    """For each contact with a neighbour: its index ``i``, the offsets ``p_j - p_i`` ((k, 3),
    metres) to the neighbours within ``radius_m`` whose normal is within ``arccos(same_side_cosine)``
    of its own and at least :data:`MIN_GAP_M` away, and the curvature ``kappa_ij`` along each ((k,),
    1/m, convex positive).

    Parameters
    ----------
    points : (n, 3) float
        Contact positions, one frame, metres.
    normals : (n, 3) float
        Their measured outward unit normals, the same frame.
    """
    points = np.asarray(points, float).reshape(-1, 3)
    normals = np.asarray(normals, float).reshape(-1, 3)
    if len(points) < 2:
        return
    for i, near in enumerate(cKDTree(points).query_ball_point(points, radius_m)):
        near = np.array([j for j in near if j != i], int)
        if len(near) == 0:
            continue
        step = points[near] - points[i]
        gap2 = np.einsum("ij,ij->i", step, step)
        keep = (normals[near] @ normals[i] > same_side_cosine) & (gap2 > MIN_GAP_M**2)
        step, gap2 = step[keep], gap2[keep]
        yield i, step, np.einsum("ij,ij->i", normals[near[keep]] - normals[i], step) / gap2
