"""Closed triangle meshes lofted through a sequence of circles between two poles.

A loft is a sphere-like (genus 0) surface: a first pole, a list of circular rings, a last pole.
Neighbouring rings may have different vertex counts; they are stitched by walking both rings in order
of their angular parameter. :func:`ring_vertex_count` picks multiples of six, so near a pole the
rings hold 6, 12, 18, ... vertices and form the near-equilateral hexagonal pattern; runs of rings
with equal counts are staggered by half a step (isosceles rather than right triangles) unless
``stagger`` is off. Surfaces of revolution are the special case built by :func:`revolve`.

Winding convention: ring angles increase counter-clockwise about the travel direction (first pole to
last pole); with the material on the left of a profile travelled pole to pole the face normals point
outward.
"""
from __future__ import annotations

import numpy as np
import trimesh

COUNT_MULTIPLE = 6


def ring_vertex_count(circumference_m: float, arc_step_m: float) -> int:
    """Smallest multiple of six vertices that keeps neighbours on a ring at most ``arc_step_m`` apart."""
    if arc_step_m <= 0:
        raise ValueError(f"arc_step_m must be positive, got {arc_step_m}")
    groups = int(np.ceil(circumference_m / (COUNT_MULTIPLE * arc_step_m) - 1e-9))
    return COUNT_MULTIPLE * max(1, groups)


def _stitch(first: int, n_first: int, half_first: bool, second: int, n_second: int, half_second: bool,
            ) -> list[tuple[int, int, int]]:
    """Triangles joining ring ``first`` (n_first vertices) to the next ring ``second``.

    Walks both rings in order of their angular parameter (v + h) / n, h = 0 or 1/2, always advancing
    the ring whose next gap is centred first, so each new rung spans the smaller angle (integer
    comparison, so deterministic).
    """
    triangles = []
    i = j = 0
    while i < n_first or j < n_second:
        next_first = (2 * i + 1 + half_first) * n_second
        next_second = (2 * j + 1 + half_second) * n_first
        a, b = first + i % n_first, second + j % n_second
        if j == n_second or (i < n_first and next_first <= next_second):
            triangles.append((a, first + (i + 1) % n_first, b))
            i += 1
        else:
            triangles.append((a, second + (j + 1) % n_second, b))
            j += 1
    return triangles


def _half_steps(counts: list[int], stagger: bool) -> list[bool]:
    """Stagger flags: within a run of rings with equal counts, every other ring turns half a step."""
    flags = [False]
    for k in range(1, len(counts)):
        flags.append(stagger and counts[k] == counts[k - 1] and not flags[-1])
    return flags


def loft(centres: np.ndarray, axes_u: np.ndarray, axes_v: np.ndarray, radii_m: np.ndarray,
         counts: list[int], first_pole: np.ndarray, last_pole: np.ndarray, stagger: bool = True,
         ) -> trimesh.Trimesh:
    """Watertight mesh through circular rings capped by two pole vertices.

    Ring k holds ``counts[k]`` points ``centres[k] + radii_m[k] (cos t axes_u[k] + sin t axes_v[k])``
    with t = 2 pi (v + h_k) / counts[k] and h_k in {0, 1/2} (see the module docstring).

    Parameters
    ----------
    centres, axes_u, axes_v : (m, 3) float
        Ring centres (metres) and orthonormal in-plane axes; ``axes_u x axes_v`` points along the
        direction of travel. ``axes_u`` sets the common angular reference, so it must vary smoothly.
    radii_m : (m,) float
        Ring radii, metres, positive.
    counts : sequence of m int
        Vertices per ring, at least 3.
    first_pole, last_pole : (3,) float
        The two pole vertices, metres.
    stagger : bool
        Turn every other ring of an equal-count run by half a step. Right for doubly curved
        surfaces; switch off for straight (cylindrical) runs, where aligned rings give flat quads
        and keep a convex shape convex.

    Returns
    -------
    trimesh.Trimesh
        Vertex order: first pole, the rings in order, last pole.
    """
    centres, axes_u, axes_v = (np.atleast_2d(np.asarray(a, float)) for a in (centres, axes_u, axes_v))
    radii_m = np.atleast_1d(np.asarray(radii_m, float))
    counts = [int(c) for c in counts]
    m = len(radii_m)
    if m == 0:
        raise ValueError("loft needs at least one ring")
    if not (centres.shape == axes_u.shape == axes_v.shape == (m, 3)) or len(counts) != m:
        raise ValueError(f"loft: centres/axes must be (m, 3) and counts length m, with m = {m} radii")
    if np.any(radii_m <= 0) or min(counts) < 3:
        raise ValueError("loft: ring radii must be positive and counts at least 3")

    half = _half_steps(counts, stagger)
    rings = []
    for k in range(m):
        angle = 2.0 * np.pi * (np.arange(counts[k]) + (0.5 if half[k] else 0.0)) / counts[k]
        rings.append(centres[k] + radii_m[k] * (np.cos(angle)[:, None] * axes_u[k] + np.sin(angle)[:, None] * axes_v[k]))

    starts = [1 + int(s) for s in np.concatenate([[0], np.cumsum(counts)])]
    last_index = starts[-1]
    triangles = [(0, starts[0] + (v + 1) % counts[0], starts[0] + v) for v in range(counts[0])]
    for k in range(m - 1):
        triangles += _stitch(starts[k], counts[k], half[k], starts[k + 1], counts[k + 1], half[k + 1])
    s, n = starts[m - 1], counts[m - 1]
    triangles += [(last_index, s + v, s + (v + 1) % n) for v in range(n)]

    vertices = np.vstack([np.asarray(first_pole, float)[None], *rings, np.asarray(last_pole, float)[None]])
    return trimesh.Trimesh(vertices, np.array(triangles, dtype=np.int64), process=False)


def revolve(profile_rz: np.ndarray, arc_step_m: float, stagger: bool = True) -> trimesh.Trimesh:
    """Surface of revolution about the z axis.

    Parameters
    ----------
    profile_rz : (m, 2) float
        Profile polyline (radius, z) in metres from the first pole to the last. The first and last
        points must lie on the axis (radius 0), all others off it. Keep the material on the left of
        the direction of travel in the (radius, z) half-plane for outward normals.
    arc_step_m : float
        Largest spacing of vertices around each ring, metres.
    stagger : bool
        See :func:`loft`.
    """
    profile_rz = np.asarray(profile_rz, float)
    if profile_rz.ndim != 2 or profile_rz.shape[1] != 2 or len(profile_rz) < 3:
        raise ValueError(f"profile_rz must have shape (m >= 3, 2), got {profile_rz.shape}")
    if profile_rz[0, 0] != 0.0 or profile_rz[-1, 0] != 0.0:
        raise ValueError("profile_rz must start and end on the axis (radius 0)")
    radii, heights = profile_rz[1:-1, 0], profile_rz[1:-1, 1]
    if np.any(radii <= 0.0):
        raise ValueError("interior profile points must have positive radius")
    m = len(radii)
    centres = np.column_stack([np.zeros(m), np.zeros(m), heights])
    axes_u, axes_v = np.tile([1.0, 0.0, 0.0], (m, 1)), np.tile([0.0, 1.0, 0.0], (m, 1))
    counts = [ring_vertex_count(2 * np.pi * r, arc_step_m) for r in radii]
    return loft(centres, axes_u, axes_v, radii, counts,
                [0.0, 0.0, profile_rz[0, 1]], [0.0, 0.0, profile_rz[-1, 1]], stagger)
