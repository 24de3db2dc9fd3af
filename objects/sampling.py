"""Random points spread uniformly over a mesh's surface or along line segments (seeded generators)."""
from __future__ import annotations

import numpy as np
import trimesh


def sample_surface(mesh: trimesh.Trimesh, n_samples: int, rng: np.random.Generator,
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Points uniformly distributed over the surface area of ``mesh``.

    A face is drawn with probability proportional to its area, then a point uniformly inside it
    (barycentric coordinates by the square-root rule), so zero-area faces are never drawn.

    Returns
    -------
    points : (n_samples, 3) float
        Mesh frame and units.
    face_index : (n_samples,) int
        The face each point lies on.
    """
    areas = np.asarray(mesh.area_faces, float)
    if len(areas) == 0 or not areas.sum() > 0:
        raise ValueError("cannot sample a mesh with zero surface area")
    face_index = rng.choice(len(areas), size=n_samples, p=areas / areas.sum())
    root_u, v = np.sqrt(rng.random(n_samples)), rng.random(n_samples)
    weights = np.column_stack([1 - root_u, root_u * (1 - v), root_u * v])
    corners = np.asarray(mesh.triangles, float)[face_index]
    return np.einsum("nk,nkd->nd", weights, corners), face_index


def sample_segments(segments: np.ndarray, n_samples: int, rng: np.random.Generator) -> np.ndarray:
    """Points uniformly distributed along a set of line segments (by length).

    Parameters
    ----------
    segments : (k, 2, 3) float
        Segment end points; positive total length.

    Returns
    -------
    (n_samples, 3) float
    """
    segments = np.asarray(segments, float)
    lengths = np.linalg.norm(segments[:, 1] - segments[:, 0], axis=1)
    if not lengths.sum() > 0:
        raise ValueError("cannot sample segments of zero total length")
    chosen = rng.choice(len(segments), size=n_samples, p=lengths / lengths.sum())
    t = rng.random(n_samples)[:, None]
    return segments[chosen, 0] + t * (segments[chosen, 1] - segments[chosen, 0])
