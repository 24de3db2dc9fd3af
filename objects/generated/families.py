"""The families of generated household-like solids: their parameter ranges and builders.

Each family draws its parameters from a documented range (:class:`Uniform` or :class:`Choice`) and
builds a solid from them with manifold3d CSG (booleans, revolutions, extrusions, hulls) or, for the
blob, a radially displaced sphere. Builders work in metres with the object standing on z = 0, z up;
:mod:`objects.generated.building` moves the bounding-box centre to the origin and checks the result.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Union

import numpy as np
import trimesh
from manifold3d import CrossSection, Manifold, OpType

from objects.generated.primitives import (capsule, chamfered_box, cylinder, ellipse, extrude, polygon,
                                          rectangle, revolve, round_corners, rounded_box)


@dataclass(frozen=True)
class Uniform:
    """A parameter drawn uniformly from [low, high] (metres unless ``unit`` says otherwise)."""

    low: float
    high: float
    unit: str = "m"


@dataclass(frozen=True)
class Choice:
    """A parameter drawn with equal probability from ``options``."""

    options: tuple


Shape = Union[Manifold, trimesh.Trimesh]


@dataclass(frozen=True)
class Family:
    """One family of generated objects.

    Attributes
    ----------
    name : str
        Used in object names: ``generated:<name>/<seed>``.
    summary : str
        One line: what the shapes look like.
    ranges : dict of str -> Uniform or Choice
        The parameters, drawn in this order.
    build : callable (dict) -> manifold3d.Manifold or trimesh.Trimesh
        Solid from the drawn parameters, metres, standing on z = 0.
    """

    name: str
    summary: str
    ranges: dict
    build: Callable[[dict], Shape]

    def draw(self, rng: np.random.Generator) -> dict:
        """Parameters drawn from ``rng`` in the order of :attr:`ranges`."""
        params = {}
        for key, rule in self.ranges.items():
            if isinstance(rule, Uniform):
                params[key] = float(rng.uniform(rule.low, rule.high))
            else:
                params[key] = rule.options[int(rng.integers(len(rule.options)))]
        return params


def _union(parts) -> Manifold:
    return Manifold.batch_boolean(list(parts), OpType.Add)


def _polyline_tube(points, radius_m: float) -> Manifold:
    """Union of capsules along consecutive ``points``: a tube of constant radius."""
    points = np.asarray(points, float)
    return _union(capsule(a, b, radius_m) for a, b in zip(points[:-1], points[1:]))


def _mirror_x(points) -> np.ndarray:
    """A right-half outline (x >= 0, listed bottom to top) completed by its mirror image."""
    right = np.asarray(points, float)
    left = right[::-1] * [-1.0, 1.0]
    return np.vstack([right, left])


# --- mugs and cups ------------------------------------------------------------------------------

def _mug(p: dict) -> Manifold:
    height, top, wall, base = p["height"], p["top_radius"], p["wall"], p["base"]
    bottom = top * p["taper"]
    outer = polygon([(-bottom, 0), (bottom, 0), (top, height), (-top, height)])
    cavity = polygon([(-(bottom - wall), base), (bottom - wall, base),
                      (top - wall, height + 0.05), (-(top - wall), height + 0.05)])
    shell = round_corners(outer - cavity, convex_m=0.45 * wall, concave_m=0.006)
    body = revolve(shell)
    # Trims the handle's ends 1 mm inside the wall (a cut flush with the inner surface would leave
    # near-coincident slivers).
    cavity_solid = revolve(cavity.offset(0.001))

    def mid_wall(z: float) -> float:
        return bottom + (top - bottom) * z / height - wall / 2

    z_low = height * (0.5 - p["handle_span"] / 2)
    z_high = height * (0.5 + p["handle_span"] / 2) - p["handle_tube"]
    theta = np.linspace(-np.pi / 2, np.pi / 2, 13)
    z = (z_low + z_high) / 2 + (z_high - z_low) / 2 * np.sin(theta)
    x = np.array([mid_wall(zi) for zi in z]) + p["handle_reach"] * np.cos(theta)
    handle = _polyline_tube(np.column_stack([x, np.zeros_like(x), z]), p["handle_tube"])
    return body + (handle - cavity_solid)


# --- bowls and trays -----------------------------------------------------------------------------

def _bowl(p: dict) -> Manifold:
    radius, depth, wall = p["radius"], p["depth"], p["wall"]
    foot = p["foot_height"]
    lid = rectangle(-1, foot + depth, 1, 1)
    outer = ellipse(0, foot + depth, radius, depth) - lid
    inner = ellipse(0, foot + depth, radius - wall, depth - wall)
    ring = rectangle(-p["foot_radius"], 0, p["foot_radius"], foot + 0.5 * wall)
    section = round_corners((outer - inner) + ring, convex_m=0.45 * wall, concave_m=0.004)
    return revolve(section)


def _tray(p: dict) -> Manifold:
    corner = p["corner_radius"]
    outline = round_corners(rectangle(-p["length"] / 2, -p["width"] / 2, p["length"] / 2, p["width"] / 2),
                            convex_m=corner)
    outer = extrude(outline, p["height"])
    inner = extrude(outline.offset(-p["wall"]), p["height"]).translate((0, 0, p["floor"]))
    return outer - inner


# --- bottles -------------------------------------------------------------------------------------

def _bottle(p: dict) -> Manifold:
    body_r, neck_r = p["body_radius"], p["neck_radius"]
    z1 = p["body_height"]
    z2 = z1 + p["shoulder_height"]
    z3 = z2 + p["neck_height"]
    cap_r = neck_r + p["cap_overhang"]
    section = polygon(_mirror_x([(body_r, 0), (body_r, z1), (neck_r, z2), (neck_r, z3 + 0.002)]))
    section = section + rectangle(-cap_r, z3, cap_r, z3 + p["cap_height"])
    return revolve(round_corners(section, convex_m=p["edge_radius"], concave_m=0.003))


# --- boxes ---------------------------------------------------------------------------------------

def _box_size(p: dict) -> tuple[float, float, float]:
    return p["length"], p["width"], p["height"]


def _rounded_box(p: dict) -> Manifold:
    size = _box_size(p)
    return rounded_box(size, p["edge_radius"]).translate((0, 0, size[2] / 2))


def _chamfered_box(p: dict) -> Manifold:
    size = _box_size(p)
    return chamfered_box(size, p["chamfer"]).translate((0, 0, size[2] / 2))


# --- tools ---------------------------------------------------------------------------------------

def _l_tool(p: dict) -> Manifold:
    """Drill-like: a grip (rounded box) leaning back under a horizontal barrel with a chuck."""
    grip_size = (p["grip_depth"], p["grip_width"], p["grip_length"])
    grip = rounded_box(grip_size, 0.4 * min(grip_size[:2])).rotate((0, -p["grip_lean_deg"], 0))
    grip = grip.translate((0, 0, p["grip_length"] / 2))
    barrel_z = p["grip_length"] * 0.95 + p["barrel_radius"] * 0.6
    barrel = rounded_box((p["barrel_length"], 2 * p["barrel_radius"], 2 * p["barrel_radius"]),
                         0.9 * p["barrel_radius"])
    barrel = barrel.translate((p["barrel_length"] * (0.5 - p["grip_position"]), 0, barrel_z))
    chuck_x = p["barrel_length"] * (1 - p["grip_position"])
    chuck = cylinder(p["chuck_radius"], p["chuck_length"] + 0.01).rotate((0, 90, 0))
    chuck = chuck.translate((chuck_x + (p["chuck_length"] - 0.01) / 2 - 0.003, 0, barrel_z))
    return _union([grip, barrel, chuck])


def _t_tool(p: dict) -> Manifold:
    """Hammer-like: a round handle with a block head across its top."""
    handle = capsule((0, 0, p["handle_radius"]), (0, 0, p["handle_length"]), p["handle_radius"])
    head_size = (p["head_length"], p["head_width"], p["head_width"])
    head = chamfered_box(head_size, p["head_chamfer"]).translate(
        (p["head_offset"] * p["head_length"], 0, p["handle_length"] + 0.4 * p["head_width"]))
    return handle + head


# --- plates and lids -----------------------------------------------------------------------------

def _plate(p: dict) -> Manifold:
    """A dish of constant thickness along a centre line: flat well, sloped wall, flat rim, foot."""
    radius, thick = p["radius"], p["thickness"]
    well = radius * (1 - p["rim_fraction"]) - p["wall_run"]
    r = np.array([-radius, -(well + p["wall_run"]), -well, well, well + p["wall_run"], radius - thick / 2])
    r[0] += thick / 2
    z = np.array([p["depth"] + p["rim_rise"], p["depth"], 0.0, 0.0, p["depth"], p["depth"] + p["rim_rise"]])
    z += thick / 2 + p["foot"]
    sheet = _polyline_sheet(np.column_stack([r, z]), thick / 2)
    foot_r = p["foot_radius_fraction"] * well
    section = sheet + rectangle(-foot_r, 0, foot_r, p["foot"] + thick / 2)
    return revolve(round_corners(section, concave_m=0.003))


def _polyline_sheet(points, half_thickness_m: float):
    """2-D band of half width ``half_thickness_m`` around a polyline, round at the ends and joints."""
    circle = ellipse(0, 0, half_thickness_m, half_thickness_m)
    parts = [CrossSection.batch_hull([circle.translate(tuple(a)), circle.translate(tuple(b))])
             for a, b in zip(points[:-1], points[1:])]
    return CrossSection.batch_boolean(parts, OpType.Add)


def _lid(p: dict) -> Manifold:
    """A disc with a skirt underneath (concave underside) and a knob on top."""
    radius, thick = p["radius"], p["thickness"]
    skirt = p["skirt_height"]
    disc = rectangle(-radius, skirt, radius, skirt + thick)
    ring = rectangle(-radius, 0, radius, skirt + 0.001) - rectangle(-(radius - p["skirt_wall"]), -1,
                                                                     radius - p["skirt_wall"], 1)
    top = skirt + thick
    knob = (rectangle(-p["knob_stem_radius"], top - 0.001, p["knob_stem_radius"], top + p["knob_height"])
            + ellipse(0, top + p["knob_height"], p["knob_radius"], 0.4 * p["knob_radius"]))
    section = round_corners(disc + ring + knob, convex_m=0.0015, concave_m=0.002)
    return revolve(section)


# --- tori and rings ------------------------------------------------------------------------------

def _torus(p: dict) -> Manifold:
    tube = p["tube_radius"]
    section = ellipse(p["major_radius"], tube * p["squash"], tube, tube * p["squash"])
    return revolve(section)


def _ring(p: dict) -> Manifold:
    outer = p["outer_radius"]
    inner = outer - p["radial_thickness"]
    section = rectangle(inner, 0, outer, p["height"])
    return revolve(round_corners(section, convex_m=p["edge_radius"]))


# --- organic shapes ------------------------------------------------------------------------------

def _blob(p: dict) -> trimesh.Trimesh:
    """A sphere displaced radially by an ellipsoid and a few smooth bumps (star-shaped, so the
    surface cannot intersect itself)."""
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=1.0)
    directions = sphere.vertices / np.linalg.norm(sphere.vertices, axis=1, keepdims=True)
    rng = np.random.default_rng(p["bump_seed"])
    radius = np.ones(len(directions))
    for _ in range(int(p["bumps"])):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        angle = np.arccos(np.clip(directions @ axis, -1, 1))
        radius += rng.uniform(-0.3, 0.5) * np.exp(-(angle / rng.uniform(0.35, 0.8)) ** 2)
    radius = np.maximum(radius, 0.5)
    axes = np.array([1.0, p["aspect_y"], p["aspect_z"]])
    vertices = directions * radius[:, None] * axes
    vertices *= p["size"] / float(np.max(np.ptp(vertices, axis=0)))
    vertices[:, 2] -= vertices[:, 2].min()
    return trimesh.Trimesh(vertices, sphere.faces, process=False)


def _fruit(p: dict) -> Manifold:
    r = p["radius"]
    kind = p["kind"]
    if kind == "pear":
        top_r = p["top_ratio"] * r
        body = ellipse(0, r, r, r) + ellipse(0, r + p["elongation"] * r, top_r, top_r)
        body = round_corners(body, concave_m=0.8 * r)
    elif kind == "apple":
        body = ellipse(0, r * 0.9, r, 0.9 * r) - ellipse(0, 1.8 * r, 0.25 * r, 0.15 * r)
        body = round_corners(body, convex_m=0.1 * r, concave_m=0.15 * r)
    else:  # lemon: an ellipse with pointed ends
        height = p["elongation"] * r
        body = (ellipse(0, height, r, height) + ellipse(0, 0.3 * r, 0.25 * r, 0.3 * r)
                + ellipse(0, 2 * height - 0.3 * r, 0.25 * r, 0.3 * r))
        body = round_corners(body, concave_m=0.5 * r)
    top = body.bounds()[3]
    if kind != "lemon":
        body = body + rectangle(-p["stem_radius"], top - 0.3 * r, p["stem_radius"], top + p["stem_length"])
        body = round_corners(body, concave_m=0.003)
    solid = revolve(body)
    return solid - Manifold.cube((1, 1, 1), True).translate((0, 0, -0.5))  # never below z = 0


# --- sharp-edged prisms --------------------------------------------------------------------------

def _wedge(p: dict) -> Manifold:
    """A door-stop wedge: right-triangle profile in x-z extruded along y, with a blunt tip."""
    length, height = p["length"], p["height"]
    tip = p["tip"]
    profile = polygon([(0, 0), (length, 0), (length, tip), (0, height)])
    solid = extrude(profile, p["width"]).rotate((90, 0, 0))  # profile y -> z, extrusion along -y
    return solid.translate((0, p["width"] / 2, 0))


def _prism(p: dict) -> Manifold:
    sides = int(p["sides"])
    angles = np.linspace(0, 2 * np.pi, sides, endpoint=False) + np.pi / 2
    outline = polygon(np.column_stack([np.cos(angles), np.sin(angles)]) * p["circumradius"])
    return extrude(outline, p["length"])


def _families() -> list[Family]:
    u = Uniform
    return [
        Family("mug", "mug or cup, straight or tapered wall, rounded rim, D handle", dict(
            height=u(0.07, 0.12), top_radius=u(0.035, 0.05), taper=u(0.75, 1.0, "ratio"),
            wall=u(0.003, 0.005), base=u(0.005, 0.009), handle_span=u(0.45, 0.7, "of height"),
            handle_reach=u(0.02, 0.035), handle_tube=u(0.005, 0.008)), _mug),
        Family("bowl", "half-ellipsoid bowl on a foot ring, rounded rim (concave)", dict(
            radius=u(0.06, 0.095), depth=u(0.035, 0.07), wall=u(0.003, 0.006),
            foot_height=u(0.004, 0.01), foot_radius=u(0.025, 0.04)), _bowl),
        Family("tray", "rounded-rectangle tray with sharp-rimmed walls (concave)", dict(
            length=u(0.12, 0.20), width=u(0.08, 0.14), height=u(0.02, 0.045),
            corner_radius=u(0.01, 0.03), wall=u(0.004, 0.007), floor=u(0.004, 0.007)), _tray),
        Family("bottle", "bottle: cylindrical body, conical shoulder, neck, wider cap", dict(
            body_radius=u(0.025, 0.045), body_height=u(0.06, 0.10), shoulder_height=u(0.015, 0.04),
            neck_radius=u(0.009, 0.015), neck_height=u(0.01, 0.03), cap_overhang=u(0.002, 0.004),
            cap_height=u(0.012, 0.025), edge_radius=u(0.0015, 0.004)), _bottle),
        Family("rounded_box", "box with every edge rounded", dict(
            length=u(0.08, 0.20), width=u(0.05, 0.14), height=u(0.04, 0.12),
            edge_radius=u(0.004, 0.018)), _rounded_box),
        Family("chamfered_box", "box with every edge chamfered at 45 degrees (sharp edges)", dict(
            length=u(0.08, 0.20), width=u(0.05, 0.14), height=u(0.04, 0.12),
            chamfer=u(0.004, 0.015)), _chamfered_box),
        Family("l_tool", "drill-like L: leaning grip under a barrel with a small chuck", dict(
            grip_depth=u(0.03, 0.04), grip_width=u(0.025, 0.035), grip_length=u(0.08, 0.12),
            grip_lean_deg=u(0.0, 20.0, "deg"), barrel_radius=u(0.02, 0.03),
            barrel_length=u(0.11, 0.16), grip_position=u(0.15, 0.35, "of barrel"),
            chuck_radius=u(0.006, 0.012), chuck_length=u(0.01, 0.025)), _l_tool),
        Family("t_tool", "hammer-like T: round handle, chamfered block head", dict(
            handle_radius=u(0.01, 0.016), handle_length=u(0.10, 0.16), head_length=u(0.07, 0.13),
            head_width=u(0.022, 0.035), head_chamfer=u(0.002, 0.006),
            head_offset=u(-0.2, 0.2, "of head")), _t_tool),
        Family("plate", "thin dish: flat well, sloped wall, raised flat rim, foot ring", dict(
            radius=u(0.07, 0.10), thickness=u(0.004, 0.007), depth=u(0.006, 0.018),
            rim_fraction=u(0.15, 0.3, "of radius"), wall_run=u(0.01, 0.02), rim_rise=u(0.0, 0.006),
            foot=u(0.002, 0.005), foot_radius_fraction=u(0.5, 0.8, "of well")), _plate),
        Family("lid", "pot lid: thin disc with a skirt underneath and a knob on top", dict(
            radius=u(0.045, 0.09), thickness=u(0.004, 0.008), skirt_height=u(0.008, 0.02),
            skirt_wall=u(0.003, 0.005), knob_stem_radius=u(0.005, 0.008), knob_height=u(0.01, 0.02),
            knob_radius=u(0.01, 0.016)), _lid),
        Family("torus", "torus with a round or flattened tube", dict(
            major_radius=u(0.03, 0.065), tube_radius=u(0.009, 0.02), squash=u(0.7, 1.0, "ratio")), _torus),
        Family("ring", "thick ring (tape roll) with rectangular section, slightly rounded edges", dict(
            outer_radius=u(0.035, 0.09), radial_thickness=u(0.01, 0.03), height=u(0.015, 0.06),
            edge_radius=u(0.0, 0.003)), _ring),
        Family("blob", "organic blob: ellipsoid with 3-7 smooth random bumps (a pebble, a potato)", dict(
            size=u(0.07, 0.16), aspect_y=u(0.6, 1.0, "ratio"), aspect_z=u(0.5, 0.9, "ratio"),
            bumps=Choice((3, 4, 5, 6, 7)), bump_seed=Choice(tuple(range(1000)))), _blob),
        Family("fruit", "fruit-like body of revolution (pear, apple or lemon), stem on pear and apple", dict(
            kind=Choice(("pear", "apple", "lemon")), radius=u(0.03, 0.045), top_ratio=u(0.5, 0.7, "ratio"),
            elongation=u(1.1, 1.5, "ratio"), stem_radius=u(0.003, 0.005),
            stem_length=u(0.008, 0.02)), _fruit),
        Family("wedge", "door-stop wedge: right-triangle profile, blunt 0-3 mm tip, sharp edges", dict(
            length=u(0.08, 0.18), height=u(0.025, 0.07), width=u(0.04, 0.10), tip=u(0.0005, 0.003)), _wedge),
        Family("prism", "regular 3-, 5-, 6- or 8-sided prism standing on its base, sharp edges", dict(
            sides=Choice((3, 5, 6, 8)), circumradius=u(0.03, 0.06), length=u(0.06, 0.18)), _prism),
    ]


FAMILIES: dict[str, Family] = {family.name: family for family in _families()}
