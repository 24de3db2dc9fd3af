"""A banana-like body: the smooth envelope of spheres swept along a circular arc.

The body is the union of balls of radius r(s) centred on a planar circular spine c(s) (arc length
s in [0, L]); its surface is the envelope of the spheres (a canal surface) closed by the end
spheres, which gives rounded tapered ends and a smooth (tangent-continuous) watertight surface.

The envelope touches the sphere at c(s) along the circle where (x - c) . T = -r r', i.e. the circle
of radius r sqrt(1 - r'^2) centred at c - r r' T in the plane normal to the spine tangent T
(r' = dr/ds, |r'| < 1).

Spine: an arc in the x-y plane (bent by ``BananaShape.bend_rad``), z is the thickness direction.

Meshing keeps every vertex on the surface and spaces vertices from the local curvature so the chord
error stays below a tolerance: around the rings and on the end caps with the side of a
near-equilateral triangle inscribed in a sphere of radius r, a = sqrt(6 r tol) (it sags a^2 / (6 r)
at its centre); along the spine with sqrt(8 tol / kappa) for the longitudinal curvature kappa.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from objects.lofting import loft, ring_vertex_count


@dataclass(frozen=True)
class BananaShape:
    """Dimensions of the swept body (all metres, radians).

    The radius along the spine is ``r(u) = stem (1 - u) + tip u + bulge sin(pi u)`` with
    ``u = s / spine_length``.
    """

    spine_length_m: float = 0.165
    bend_rad: float = np.radians(70.0)
    stem_radius_m: float = 0.006
    tip_radius_m: float = 0.008
    bulge_m: float = 0.0105

    def radius(self, s: np.ndarray) -> np.ndarray:
        """r(s), metres, for arc length ``s`` (metres) along the spine."""
        u = np.asarray(s, float) / self.spine_length_m
        return self.stem_radius_m * (1 - u) + self.tip_radius_m * u + self.bulge_m * np.sin(np.pi * u)

    def radius_slope(self, s: np.ndarray) -> np.ndarray:
        """dr/ds (dimensionless) for arc length ``s`` along the spine."""
        u = np.asarray(s, float) / self.spine_length_m
        return (self.tip_radius_m - self.stem_radius_m + np.pi * self.bulge_m * np.cos(np.pi * u)) / self.spine_length_m

    def radius_curvature(self, s: np.ndarray) -> np.ndarray:
        """d2r/ds2, 1/metres, for arc length ``s`` along the spine."""
        u = np.asarray(s, float) / self.spine_length_m
        return -(np.pi / self.spine_length_m) ** 2 * self.bulge_m * np.sin(np.pi * u)

    def longitudinal_curvature(self, s: np.ndarray) -> np.ndarray:
        """Upper bound on the surface's curvature along the spine at ``s``, 1/metres.

        Curvature of the radius profile plus that of the bent spine seen from the inside of the
        bend, 1 / (arc radius - r).
        """
        slope = self.radius_slope(s)
        profile = np.abs(self.radius_curvature(s)) / (1 + slope**2) ** 1.5
        return profile + 1.0 / (self.spine_length_m / self.bend_rad - self.radius(s))

    def spine_frame(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Spine point, tangent T, in-plane normal N and binormal B = z at arc length ``s``.

        The arc is centred on the y axis with its midpoint at the origin; N x B = T.

        Returns
        -------
        point, tangent, normal, binormal : (n, 3) float
        """
        s = np.atleast_1d(np.asarray(s, float))
        arc_radius = self.spine_length_m / self.bend_rad
        phi = (s - self.spine_length_m / 2) / arc_radius
        zeros, ones = np.zeros_like(phi), np.ones_like(phi)
        point = np.column_stack([arc_radius * np.sin(phi), arc_radius * (1 - np.cos(phi)), zeros])
        tangent = np.column_stack([np.cos(phi), np.sin(phi), zeros])
        normal = np.column_stack([-np.sin(phi), np.cos(phi), zeros])
        binormal = np.column_stack([zeros, zeros, ones])
        return point, tangent, normal, binormal

    def signed_distance(self, points: np.ndarray, n_spine: int = 4001) -> np.ndarray:
        """Distance of ``points`` to the union of balls, negative inside (spine sampled densely).

        Exact for points outside; inside it is the depth below the nearest ball's surface, which
        equals the true depth for points within a small distance of the surface.

        Parameters
        ----------
        points : (n, 3) float, metres, frame of :meth:`spine_frame`
        """
        s = np.linspace(0.0, self.spine_length_m, n_spine)
        centres, *_ = self.spine_frame(s)
        radii = self.radius(s)
        best = np.full(len(points), np.inf)
        for start in range(0, len(points), 512):
            chunk = np.asarray(points[start:start + 512], float)
            gaps = np.linalg.norm(chunk[:, None, :] - centres[None], axis=2) - radii[None]
            best[start:start + 512] = gaps.min(axis=1)
        return best


def _ring_step(radius_m: np.ndarray, tolerance_m: float, max_step_m: float) -> np.ndarray:
    """Vertex spacing whose triangles sag at most ``tolerance_m`` on a sphere of ``radius_m``."""
    return np.minimum(max_step_m, np.sqrt(6.0 * np.asarray(radius_m) * tolerance_m))


def banana_mesh(shape: BananaShape, tolerance_m: float, max_step_m: float) -> trimesh.Trimesh:
    """Mesh of the swept body in the spine's frame, vertices on the surface.

    Rings: envelope circles at spine stations, plus latitude circles on the two end spheres down to
    the poles; spacing from the local curvature and ``tolerance_m`` (see the module docstring),
    never above ``max_step_m``.
    """
    length = shape.spine_length_m
    if np.any(np.abs(shape.radius_slope(np.linspace(0, length, 200))) >= 1):
        raise ValueError("banana radius changes too fast along the spine (|dr/ds| must stay below 1)")

    stations = [0.0]
    while stations[-1] < length:
        kappa = float(shape.longitudinal_curvature(stations[-1]))
        stations.append(stations[-1] + min(max_step_m, np.sqrt(8.0 * tolerance_m / kappa)))
    s = np.array(stations) * (length / stations[-1])
    n_body = len(s) - 1
    point, tangent, normal, binormal = shape.spine_frame(s)
    r, slope = shape.radius(s), shape.radius_slope(s)
    centres = point - (r * slope)[:, None] * tangent
    radii = r * np.sqrt(1 - slope**2)

    def cap(index: int, polar_end: float, toward: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Latitude circles on the end sphere at spine station ``index``, pole first."""
        step = float(_ring_step(r[index], tolerance_m, max_step_m))
        n_cap = max(2, int(np.ceil(r[index] * polar_end / step)))
        polar = polar_end * np.arange(1, n_cap) / n_cap
        cap_centres = point[index] + toward * r[index] * np.cos(polar)[:, None] * tangent[index]
        pole = point[index] + toward * r[index] * tangent[index]
        return cap_centres, r[index] * np.sin(polar), pole

    first_centres, first_radii, first_pole = cap(0, float(np.arccos(slope[0])), -1.0)
    last_centres, last_radii, last_pole = cap(n_body, float(np.arccos(-slope[-1])), +1.0)

    all_centres = np.vstack([first_centres, centres, last_centres[::-1]])
    all_radii = np.concatenate([first_radii, radii, last_radii[::-1]])
    sphere_radii = np.concatenate([np.full(len(first_radii), r[0]), r, np.full(len(last_radii), r[-1])])
    axes_u = np.vstack([np.repeat(normal[:1], len(first_radii), 0), normal,
                        np.repeat(normal[-1:], len(last_radii), 0)])
    axes_v = np.vstack([np.repeat(binormal[:1], len(first_radii), 0), binormal,
                        np.repeat(binormal[-1:], len(last_radii), 0)])
    steps = _ring_step(sphere_radii, tolerance_m, max_step_m)
    counts = [ring_vertex_count(2 * np.pi * radius, step) for radius, step in zip(all_radii, steps)]
    return loft(all_centres, axes_u, axes_v, all_radii, counts, first_pole, last_pole)
