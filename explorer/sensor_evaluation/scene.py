"""Where to put a test object so that the pad's fixed approach line meets a chosen surface patch.

The arm always approaches along the same line (the pad's axis at the robot's home pose); the object
is posed instead, so that the line hits its surface at a chosen point with a chosen outward normal.
Each supported object has a family of *touch sites* (point and outward normal in the object frame)
away from edges and rims, so that every press lands on the smooth or flat part of the surface.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import trimesh

from objects import ObjectModel

SUPPORTED_OBJECTS = ("flat", "sphere", "cylinder")
"""Objects with touch sites: the flat slab's top face, the sphere, the cylinder's side."""

_SITE_MARGIN_M = 0.03
"""Touch sites keep this far from the flat slab's and the cylinder's edges (the pad is 18 mm wide
and slides a few millimetres while it aligns)."""


@dataclass(frozen=True)
class TouchSite:
    """A point on an object's surface with its outward unit normal, object frame.

    Attributes
    ----------
    point_m : (3,) float, object frame, metres
    normal : (3,) float, object frame, outward unit normal
    """

    point_m: np.ndarray
    normal: np.ndarray


@dataclass(frozen=True)
class ObjectPose:
    """Placement of an object in the world.

    Attributes
    ----------
    position_m : (3,) float, world frame, metres (the object frame's origin)
    rotation : (3, 3) float, object frame -> world
    """

    position_m: np.ndarray
    rotation: np.ndarray

    def to_world(self, points_m: np.ndarray) -> np.ndarray:
        """Object-frame points ((..., 3) metres) in the world frame."""
        return np.asarray(points_m, dtype=float) @ self.rotation.T + self.position_m


def check_object_name(name: str) -> str:
    """``name`` if it is one of :data:`SUPPORTED_OBJECTS`; ValueError naming the choices otherwise."""
    if name not in SUPPORTED_OBJECTS:
        raise ValueError(f"unknown or unsupported test object {name!r}; choose from {', '.join(SUPPORTED_OBJECTS)}")
    return name


def random_touch_site(model: ObjectModel, rng: np.random.Generator) -> TouchSite:
    """A random site on the part of ``model`` meant to be touched (see :data:`SUPPORTED_OBJECTS`).

    Sizes come from the mesh's bounding box: the slab's top face is its highest z, the sphere's and
    the cylinder's radius half the x extent, the cylinder's axis the object's z axis.
    """
    check_object_name(model.name)
    centre, extent = np.asarray(model.centre_m, float), np.asarray(model.extent_m, float)
    if model.name == "flat":
        half = extent[:2] / 2.0 - _SITE_MARGIN_M
        xy = centre[:2] + rng.uniform(-half, half)
        return TouchSite(np.array([xy[0], xy[1], centre[2] + extent[2] / 2.0]), np.array([0.0, 0.0, 1.0]))
    radius = extent[0] / 2.0
    if model.name == "sphere":
        direction = rng.standard_normal(3)
        direction /= np.linalg.norm(direction)
        return TouchSite(centre + radius * direction, direction)
    angle = rng.uniform(0.0, 2.0 * math.pi)
    radial = np.array([math.cos(angle), math.sin(angle), 0.0])
    height = rng.uniform(-1.0, 1.0) * max(extent[2] / 2.0 - _SITE_MARGIN_M, 0.0)
    return TouchSite(centre + radius * radial + np.array([0.0, 0.0, height]), radial)


def tilted_normal(approach_dir, tilt_rad: float, azimuth_rad: float) -> np.ndarray:
    """Outward surface normal tilted by ``tilt_rad`` from facing the approach head-on.

    Parameters
    ----------
    approach_dir : (3,) float
        Unit approach direction, world frame (the pad moves along it into the surface).
    tilt_rad : float
        Angle between the normal and ``-approach_dir``, radians, in [0, pi/2).
    azimuth_rad : float
        Direction of the tilt about the approach axis, radians (0: towards the world-horizontal
        direction perpendicular to the approach, or world x when approaching vertically).

    Returns
    -------
    (3,) float, world frame, unit.
    """
    a = _unit(approach_dir, "approach_dir")
    if not 0.0 <= tilt_rad < math.pi / 2:
        raise ValueError(f"tilt must be in [0, 90) degrees, got {math.degrees(tilt_rad):.1f}")
    e1, e2 = _perpendicular_basis(a)
    sideways = math.cos(azimuth_rad) * e1 + math.sin(azimuth_rad) * e2
    return -math.cos(tilt_rad) * a + math.sin(tilt_rad) * sideways


def pose_for_contact(site: TouchSite, point_world_m, normal_world, spin_rad: float = 0.0) -> ObjectPose:
    """The object pose that puts ``site`` at ``point_world_m`` with its normal along ``normal_world``.

    ``spin_rad`` turns the object about that normal (which part of it lies around the site).
    """
    target = _unit(normal_world, "normal_world")
    point = np.asarray(point_world_m, dtype=float)
    if point.shape != (3,) or not np.all(np.isfinite(point)):
        raise ValueError(f"point_world_m must be 3 finite numbers, got {point_world_m!r}")
    rotation = _rotation_about(target, spin_rad) @ _rotation_taking(np.asarray(site.normal, float), target)
    return ObjectPose(point - rotation @ np.asarray(site.point_m, float), rotation)


def free_gap_m(model: ObjectModel, pose: ObjectPose, face_points_m, approach_dir) -> float:
    """How far the pad can move along ``approach_dir`` before any face point meets the object.

    Parameters
    ----------
    face_points_m : (k, 3) float
        Sample points of the pad face, world frame, metres.
    approach_dir : (3,) float
        Unit approach direction, world frame.

    Returns
    -------
    float, metres; ``inf`` when no ray hits.
    """
    a = _unit(approach_dir, "approach_dir")
    origins = np.asarray(face_points_m, dtype=float)
    mesh = trimesh.Trimesh(pose.to_world(model.mesh.vertices), model.mesh.faces, process=False)
    locations, ray_index, _ = mesh.ray.intersects_location(origins, np.tile(a, (len(origins), 1)))
    if len(locations) == 0:
        return math.inf
    depths = np.einsum("ij,j->i", locations - origins[ray_index], a)
    return float(depths[depths > -1e-9].min(initial=math.inf))


def _unit(vector, name: str) -> np.ndarray:
    v = np.asarray(vector, dtype=float)
    norm = np.linalg.norm(v) if v.shape == (3,) else 0.0
    if v.shape != (3,) or not np.all(np.isfinite(v)) or norm < 1e-12:
        raise ValueError(f"{name} must be a finite non-zero 3-vector, got {vector!r}")
    return v / norm


def _perpendicular_basis(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    helper = np.array([0.0, 0.0, 1.0]) if abs(a[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    e1 = np.cross(a, helper)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(a, e1)


def _rotation_about(axis: np.ndarray, angle: float) -> np.ndarray:
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * k @ k


def _rotation_taking(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """The smallest rotation turning unit vector ``source`` onto unit vector ``target``."""
    axis = np.cross(source, target)
    sin, cos = np.linalg.norm(axis), float(source @ target)
    if sin < 1e-12:
        if cos > 0.0:
            return np.eye(3)
        return _rotation_about(_perpendicular_basis(source)[0], math.pi)
    return _rotation_about(axis / sin, math.atan2(sin, cos))
