"""Plain data for a URDF robot (links, joints, shapes) and a deterministic URDF writer.

Inertias are computed from the collision shapes (solid bodies of uniform density), so a link is
described by its mass and its geometry only. All lengths in metres, masses in kilograms, angles in
radians, efforts in N m, velocities in rad/s.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from xml.sax.saxutils import quoteattr

import numpy as np

Vec3 = tuple[float, float, float]
ZERO3: Vec3 = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Box:
    """Box with edge lengths ``size_m`` (x, y, z) centred on its frame."""

    size_m: Vec3

    def volume(self) -> float:
        return float(np.prod(self.size_m))

    def unit_inertia(self) -> np.ndarray:
        """Inertia tensor per kilogram about the centre, (3, 3)."""
        x, y, z = self.size_m
        return np.diag([y * y + z * z, x * x + z * z, x * x + y * y]) / 12.0


@dataclass(frozen=True)
class Cylinder:
    """Solid cylinder along its frame's z axis, centred on its frame."""

    radius_m: float
    length_m: float

    def volume(self) -> float:
        return math.pi * self.radius_m**2 * self.length_m

    def unit_inertia(self) -> np.ndarray:
        r, h = self.radius_m, self.length_m
        side = (3.0 * r * r + h * h) / 12.0
        return np.diag([side, side, r * r / 2.0])


@dataclass(frozen=True)
class Sphere:
    """Solid sphere centred on its frame."""

    radius_m: float

    def volume(self) -> float:
        return 4.0 / 3.0 * math.pi * self.radius_m**3

    def unit_inertia(self) -> np.ndarray:
        return np.eye(3) * 0.4 * self.radius_m**2


Geometry = Box | Cylinder | Sphere


@dataclass(frozen=True)
class Shape:
    """A geometry placed in a link frame (``xyz`` translation, ``rpy`` fixed-axis roll-pitch-yaw)."""

    geometry: Geometry
    xyz: Vec3 = ZERO3
    rpy: Vec3 = ZERO3


@dataclass(frozen=True)
class Link:
    """A rigid link: mass spread uniformly over its collision shapes.

    ``visual_only`` shapes are drawn but neither collide nor carry mass. A link with no shapes
    carries its mass as a point-like cube of ``POINT_MASS_SIZE_M`` at the frame origin.
    """

    name: str
    mass_kg: float
    shapes: tuple[Shape, ...] = ()
    visual_only: tuple[Shape, ...] = ()
    rgba: tuple[float, float, float, float] = (0.7, 0.7, 0.7, 1.0)


@dataclass(frozen=True)
class Joint:
    """A URDF joint; ``lower``/``upper``/``effort``/``velocity`` are ignored for fixed joints."""

    name: str
    kind: str  # "revolute" or "fixed"
    parent: str
    child: str
    xyz: Vec3 = ZERO3
    rpy: Vec3 = ZERO3
    axis: Vec3 = (0.0, 0.0, 1.0)
    lower: float = 0.0
    upper: float = 0.0
    effort: float = 0.0
    velocity: float = 0.0
    damping: float = 0.0
    friction: float = 0.0


@dataclass(frozen=True)
class RobotModel:
    """A whole robot: links and joints in writing order (parents before children)."""

    name: str
    links: tuple[Link, ...]
    joints: tuple[Joint, ...] = field(default=())


POINT_MASS_SIZE_M = 0.004


def cylinder_along_z(radius_m: float, z_from_m: float, z_to_m: float) -> Shape:
    """A cylinder on the link's z axis spanning ``z_from_m`` .. ``z_to_m``."""
    return Shape(Cylinder(radius_m, abs(z_to_m - z_from_m)), xyz=(0.0, 0.0, (z_from_m + z_to_m) / 2.0))


def cylinder_across(radius_m: float, length_m: float, axis: str) -> Shape:
    """A cylinder centred on the link origin, lying along the link's ``"x"`` or ``"y"`` axis."""
    if axis not in ("x", "y"):
        raise ValueError(f"axis must be 'x' or 'y', got {axis!r}")
    rpy = (math.pi / 2.0, 0.0, 0.0) if axis == "y" else (0.0, math.pi / 2.0, 0.0)
    return Shape(Cylinder(radius_m, length_m), rpy=rpy)


def rpy_matrix(rpy: Vec3) -> np.ndarray:
    """URDF fixed-axis roll-pitch-yaw to a rotation matrix R = Rz(yaw) Ry(pitch) Rx(roll)."""
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def link_inertia(link: Link) -> tuple[np.ndarray, np.ndarray]:
    """Centre of mass (3,) and inertia tensor (3, 3) about it, link frame, SI units.

    Mass is shared among the collision shapes in proportion to their volumes.
    """
    if link.mass_kg <= 0.0:
        raise ValueError(f"link {link.name!r}: mass must be positive, got {link.mass_kg}")
    shapes = link.shapes or (Shape(Box((POINT_MASS_SIZE_M,) * 3)),)
    volumes = np.array([s.geometry.volume() for s in shapes])
    masses = link.mass_kg * volumes / volumes.sum()
    centres = np.array([s.xyz for s in shapes], dtype=float)
    com = masses @ centres / link.mass_kg
    inertia = np.zeros((3, 3))
    for shape, mass, centre in zip(shapes, masses, centres):
        rot = rpy_matrix(shape.rpy)
        local = mass * rot @ shape.geometry.unit_inertia() @ rot.T
        d = centre - com
        inertia += local + mass * (d @ d * np.eye(3) - np.outer(d, d))
    # drop rounding noise (e.g. 1e-20 products of inertia from 90-degree shape rotations)
    inertia[np.abs(inertia) < 1e-12 * np.abs(np.diag(inertia)).max()] = 0.0
    com[np.abs(com) < 1e-15] = 0.0
    return com, inertia


def _num(value: float) -> str:
    """Deterministic, round-trippable number text (no '-0')."""
    value = float(value)
    if value == 0.0:
        return "0"
    text = f"{value:.12g}"
    return text


def _vec(values) -> str:
    return " ".join(_num(v) for v in values)


def _origin(xyz: Vec3, rpy: Vec3) -> str:
    return f'<origin xyz="{_vec(xyz)}" rpy="{_vec(rpy)}"/>'


def _geometry(geometry: Geometry) -> str:
    if isinstance(geometry, Box):
        return f'<box size="{_vec(geometry.size_m)}"/>'
    if isinstance(geometry, Cylinder):
        return f'<cylinder radius="{_num(geometry.radius_m)}" length="{_num(geometry.length_m)}"/>'
    return f'<sphere radius="{_num(geometry.radius_m)}"/>'


def _link_xml(link: Link) -> list[str]:
    com, inertia = link_inertia(link)
    lines = [f"  <link name={quoteattr(link.name)}>"]
    lines.append("    <inertial>")
    lines.append(f"      {_origin(tuple(com), ZERO3)}")
    lines.append(f'      <mass value="{_num(link.mass_kg)}"/>')
    lines.append(
        "      <inertia "
        f'ixx="{_num(inertia[0, 0])}" ixy="{_num(inertia[0, 1])}" ixz="{_num(inertia[0, 2])}" '
        f'iyy="{_num(inertia[1, 1])}" iyz="{_num(inertia[1, 2])}" izz="{_num(inertia[2, 2])}"/>'
    )
    lines.append("    </inertial>")
    colour = f'<material name={quoteattr(link.name + "_colour")}><color rgba="{_vec(link.rgba)}"/></material>'
    for shape in link.shapes + link.visual_only:
        lines.append("    <visual>")
        lines.append(f"      {_origin(shape.xyz, shape.rpy)}")
        lines.append(f"      <geometry>{_geometry(shape.geometry)}</geometry>")
        lines.append(f"      {colour}")
        lines.append("    </visual>")
    for shape in link.shapes:
        lines.append("    <collision>")
        lines.append(f"      {_origin(shape.xyz, shape.rpy)}")
        lines.append(f"      <geometry>{_geometry(shape.geometry)}</geometry>")
        lines.append("    </collision>")
    lines.append("  </link>")
    return lines


def _joint_xml(joint: Joint) -> list[str]:
    if joint.kind not in ("revolute", "fixed"):
        raise ValueError(f"joint {joint.name!r}: kind must be 'revolute' or 'fixed', got {joint.kind!r}")
    lines = [f"  <joint name={quoteattr(joint.name)} type={quoteattr(joint.kind)}>"]
    lines.append(f"    <parent link={quoteattr(joint.parent)}/>")
    lines.append(f"    <child link={quoteattr(joint.child)}/>")
    lines.append(f"    {_origin(joint.xyz, joint.rpy)}")
    if joint.kind == "revolute":
        if not joint.lower < joint.upper:
            raise ValueError(f"joint {joint.name!r}: lower limit {joint.lower} must be below upper {joint.upper}")
        lines.append(f'    <axis xyz="{_vec(joint.axis)}"/>')
        lines.append(
            f'    <limit lower="{_num(joint.lower)}" upper="{_num(joint.upper)}" '
            f'effort="{_num(joint.effort)}" velocity="{_num(joint.velocity)}"/>'
        )
        lines.append(f'    <dynamics damping="{_num(joint.damping)}" friction="{_num(joint.friction)}"/>')
    lines.append("  </joint>")
    return lines


def to_urdf(model: RobotModel, comment: str = "") -> str:
    """The URDF text of ``model`` (with an optional XML ``comment``); same input, same bytes."""
    names = [link.name for link in model.links]
    if len(set(names)) != len(names):
        raise ValueError(f"robot {model.name!r}: duplicate link names in {names}")
    known = set(names)
    for joint in model.joints:
        for end in (joint.parent, joint.child):
            if end not in known:
                raise ValueError(f"joint {joint.name!r} refers to unknown link {end!r}")
    if "--" in comment:
        raise ValueError("an XML comment may not contain '--'")
    lines = ['<?xml version="1.0"?>']
    if comment:
        lines.append(f"<!-- {comment} -->")
    lines.append(f"<robot name={quoteattr(model.name)}>")
    for link in model.links:
        lines.extend(_link_xml(link))
    for joint in model.joints:
        lines.extend(_joint_xml(joint))
    lines.append("</robot>")
    return "\n".join(lines) + "\n"
