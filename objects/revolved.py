"""Round ground-truth shapes built as surfaces of revolution about z: sphere, cylinder, bowl.

Every profile vertex lies on the analytic surface, so the mesh is inscribed in the shape and its
discretisation error is the chord sagitta, bounded by choosing the spacings (see objects/README.md).
"""
from __future__ import annotations

import numpy as np
import trimesh

from objects.lofting import revolve


def _count(length_m: float, step_m: float) -> int:
    """Number of intervals of at most ``step_m`` covering ``length_m``."""
    return max(1, int(np.ceil(length_m / step_m - 1e-9)))


def sphere_mesh(radius_m: float, step_m: float) -> trimesh.Trimesh:
    """Sphere centred at the origin; vertices at most ``step_m`` apart along meridians and rings."""
    n = max(2, _count(np.pi * radius_m, step_m))
    polar = np.pi * np.arange(n + 1) / n
    profile = np.column_stack([radius_m * np.sin(polar), -radius_m * np.cos(polar)])
    profile[[0, -1], 0] = 0.0
    return revolve(profile, step_m)


def cylinder_mesh(radius_m: float, height_m: float, arc_step_m: float, cap_step_m: float,
                  side_step_m: float) -> trimesh.Trimesh:
    """Closed cylinder about z centred at the origin (flat caps, sharp rims).

    ``arc_step_m`` spaces vertices around the rings (sets the chord error of the side),
    ``cap_step_m`` spaces the cap rings radially and ``side_step_m`` spaces the rings along z; flat
    parts carry no discretisation error, so the last two only shape the triangles.
    """
    n_cap, n_side = _count(radius_m, cap_step_m), _count(height_m, side_step_m)
    cap_radii = radius_m * np.arange(1, n_cap + 1) / n_cap
    side_z = height_m * (np.arange(1, n_side) / n_side - 0.5)
    half = height_m / 2.0
    profile = np.vstack([
        [[0.0, -half]],
        np.column_stack([cap_radii, np.full(n_cap, -half)]),
        np.column_stack([np.full(n_side - 1, radius_m), side_z]),
        np.column_stack([cap_radii[::-1], np.full(n_cap, half)]),
        [[0.0, half]],
    ])
    return revolve(profile, arc_step_m, stagger=False)


def bowl_profile(outer_radius_m: float, wall_m: float, step_m: float, rim_segments: int) -> np.ndarray:
    """Profile (radius, z) of a hemispherical shell with a half-torus rim, rim centre at z = 0.

    Runs from the outer pole (0, -outer) up the outer sphere, over the rim (a half circle of
    diameter ``wall_m``) and down the inner sphere to the inner pole (0, -(outer - wall)).

    Returns
    -------
    (m, 2) float, metres
    """
    inner = outer_radius_m - wall_m
    rim_centre, rim_radius = outer_radius_m - wall_m / 2.0, wall_m / 2.0
    n_outer = _count(np.pi / 2 * outer_radius_m, step_m)
    n_inner = _count(np.pi / 2 * inner, step_m)
    polar_out = (np.pi / 2) * np.arange(n_outer + 1) / n_outer
    polar_in = (np.pi / 2) * np.arange(n_inner, -1, -1) / n_inner
    rim = np.pi * np.arange(1, rim_segments) / rim_segments
    profile = np.vstack([
        np.column_stack([outer_radius_m * np.sin(polar_out), -outer_radius_m * np.cos(polar_out)]),
        np.column_stack([rim_centre + rim_radius * np.cos(rim), rim_radius * np.sin(rim)]),
        np.column_stack([inner * np.sin(polar_in), -inner * np.cos(polar_in)]),
    ])
    profile[[0, -1], 0] = 0.0
    return profile


def bowl_mesh(outer_radius_m: float, wall_m: float, step_m: float, rim_segments: int) -> trimesh.Trimesh:
    """Hemispherical bowl, opening up (+z), rim centre circle at z = 0 (see :func:`bowl_profile`)."""
    if not 0.0 < wall_m < outer_radius_m:
        raise ValueError(f"wall_m must lie in (0, outer_radius_m), got {wall_m}")
    return revolve(bowl_profile(outer_radius_m, wall_m, step_m, rim_segments), step_m)
