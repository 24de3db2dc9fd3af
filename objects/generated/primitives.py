"""Small CSG building blocks on manifold3d for the generated families (metres).

Tessellation is explicit everywhere (no manifold3d global defaults, which are process-wide state):
circles and revolutions get a segment count from their radius so that chords stay near
:data:`CHORD_STEP_M` long.
"""
from __future__ import annotations

import math

import numpy as np
from manifold3d import CrossSection, JoinType, Manifold

#: Target length of a tessellation chord on curved surfaces, metres.
CHORD_STEP_M = 0.004
#: Outline vertices closer than this to the line through their neighbours are dropped, metres.
SIMPLIFY_M = 2e-5
#: Segment counts are kept between these bounds (a 1 mm fillet still gets a round corner).
MIN_SEGMENTS, MAX_SEGMENTS = 16, 128


def segments(radius_m: float, step_m: float = CHORD_STEP_M) -> int:
    """Number of segments for a full circle of ``radius_m``; a multiple of 4 so quadrants align."""
    n = math.ceil(2 * math.pi * radius_m / step_m)
    return int(min(MAX_SEGMENTS, max(MIN_SEGMENTS, 4 * math.ceil(n / 4))))


def polygon(points) -> CrossSection:
    """A cross-section from one closed (k, 2) outline in either orientation."""
    pts = np.asarray(points, float)
    x, y = pts[:, 0], pts[:, 1]
    if np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y) < 0:  # clockwise -> reverse
        pts = pts[::-1]
    return CrossSection([pts])


def rectangle(x0: float, y0: float, x1: float, y1: float) -> CrossSection:
    """Axis-aligned rectangle with corners (x0, y0) and (x1, y1)."""
    return polygon([(x0, y0), (x1, y0), (x1, y1), (x0, y1)])


def ellipse(cx: float, cy: float, rx: float, ry: float) -> CrossSection:
    """Ellipse with centre (cx, cy) and semi-axes rx, ry."""
    n = segments(max(rx, ry))
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return polygon(np.column_stack([cx + rx * np.cos(t), cy + ry * np.sin(t)]))


def round_corners(section: CrossSection, convex_m: float = 0.0, concave_m: float = 0.0) -> CrossSection:
    """Fillet convex corners with radius ``convex_m`` (open: shrink then grow) and concave corners
    with ``concave_m`` (close: grow then shrink)."""
    if convex_m > 0:
        n = segments(convex_m, step_m=min(CHORD_STEP_M, convex_m / 2))
        section = section.offset(-convex_m, JoinType.Round, circular_segments=n)
        section = section.offset(convex_m, JoinType.Round, circular_segments=n)
    if concave_m > 0:
        n = segments(concave_m, step_m=min(CHORD_STEP_M, concave_m / 2))
        section = section.offset(concave_m, JoinType.Round, circular_segments=n)
        section = section.offset(-concave_m, JoinType.Round, circular_segments=n)
    # Offsetting a finely sampled curve adds a round join at every vertex: drop the redundant ones.
    return section.simplify(SIMPLIFY_M)


def revolve(section: CrossSection, degrees: float = 360.0) -> Manifold:
    """Solid of revolution about z of the part of ``section`` (x = radius, y = z) at x >= 0."""
    radius = max(float(section.bounds()[2]), 1e-3)
    return Manifold.revolve(section, segments(radius), degrees)


def extrude(section: CrossSection, height_m: float) -> Manifold:
    """``section`` in the x-y plane extruded from z = 0 to z = ``height_m``."""
    return Manifold.extrude(section, height_m)


def cylinder(radius_m: float, height_m: float, centred: bool = True) -> Manifold:
    """Cylinder along z, radius ``radius_m``; centred on the origin or standing on z = 0."""
    return Manifold.cylinder(height_m, radius_m, radius_m, segments(radius_m), centred)


def sphere(radius_m: float) -> Manifold:
    """Sphere about the origin."""
    return Manifold.sphere(radius_m, segments(radius_m))


def capsule(a, b, radius_m: float) -> Manifold:
    """Convex hull of two spheres of ``radius_m`` at points ``a`` and ``b``."""
    ball = sphere(radius_m)
    return Manifold.batch_hull([ball.translate(tuple(map(float, a))), ball.translate(tuple(map(float, b)))])


def rounded_box(size_m, radius_m: float) -> Manifold:
    """Box of ``size_m`` (x, y, z) centred on the origin, every edge rounded with ``radius_m``."""
    half = np.asarray(size_m, float) / 2 - radius_m
    ball = sphere(radius_m)
    corners = [ball.translate((sx * half[0], sy * half[1], sz * half[2]))
               for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    return Manifold.batch_hull(corners)


def chamfered_box(size_m, chamfer_m: float) -> Manifold:
    """Box of ``size_m`` centred on the origin with every edge cut by a 45-degree ``chamfer_m``."""
    h = np.asarray(size_m, float) / 2
    c = chamfer_m
    points = []
    for sx in (-1, 1):
        for sy in (-1, 1):
            for sz in (-1, 1):
                points += [(sx * h[0], sy * (h[1] - c), sz * (h[2] - c)),
                           (sx * (h[0] - c), sy * h[1], sz * (h[2] - c)),
                           (sx * (h[0] - c), sy * (h[1] - c), sz * h[2])]
    return Manifold.hull_points(np.asarray(points, float))
