"""How much of an object the arm and stand can reach at all."""
from __future__ import annotations

import numpy as np

from explorer.touch import Touch


def reachable_fraction(planner, mesh, n_samples: int = 48, seed: int = 0, progress=None) -> float:
    """Fraction of the surface area the arm can touch along the inward normal from some stand pose.

    Samples area-uniform points of ``mesh`` (object frame) and asks the planner for a plan to each
    (standoff and approach path solved, arm clear of the prior box).

    Parameters
    ----------
    planner : explorer.planner.ApproachPlanner
    mesh : trimesh.Trimesh, object frame
    n_samples : int
    progress : callable(int) or None
        Called with the number of points done after each one (the step takes 10-40 s).
    """
    from objects.sampling import sample_surface

    points, faces = sample_surface(mesh, n_samples, np.random.default_rng(seed))
    normals = mesh.face_normals[faces]
    reachable = []
    for point, normal in zip(points, normals):
        reachable.append(planner.plan(Touch(point, -normal, depth_m=0.005)) is not None)
        if progress is not None:
            progress(len(reachable))
    return float(np.mean(reachable))
