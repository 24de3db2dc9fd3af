"""The arm's collision primitives placed by forward kinematics: exact distances to points.

:mod:`robots.link_spheres` covers the same URDF shapes with spheres, for a planner that asks about
thousands of configurations and wants a conservative answer. The spheres overshoot a flat part by
much: ARMAR-III's 60 x 30 x 70 mm wrist box becomes 36 mm spheres, 21 mm beyond its thin sides. A
check that must be neither conservative nor optimistic, such as "does the hand at this standoff sit
on a point the pad has already touched" (:class:`explorer.planner.ApproachPlanner`), asks this model:
the signed distance from points to every box, cylinder and sphere of the chosen links, for a few
configurations at a time.
"""
from __future__ import annotations

import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from robots.urdf_check import _floats
from robots.urdf_model import rpy_matrix

#: URDF collision geometries this model handles.
PRIMITIVE_KINDS = ("box", "cylinder", "sphere")


@dataclass(frozen=True)
class Primitive:
    """One collision primitive of a link.

    Attributes
    ----------
    link : str
    kind : str
        ``"box"``, ``"cylinder"`` (axis along its own z) or ``"sphere"``.
    half_m : (3,) or (2,) or (1,) float
        Box: half sizes along x, y, z; cylinder: radius and half length; sphere: radius. Metres.
    rotation : (3, 3) float
        Primitive frame -> link frame.
    origin_m : (3,) float
        Primitive centre, link frame, metres.
    """

    link: str
    kind: str
    half_m: np.ndarray
    rotation: np.ndarray
    origin_m: np.ndarray


def collision_elements(urdf_path: Path, links) -> list[tuple[str, list]]:
    """For each of ``links`` (in that order), ``(link, [(geometry element, rotation (3, 3) primitive
    -> link frame, origin (3,) metres), ...])`` of its ``<collision>`` elements in the URDF at
    ``urdf_path`` (read once); ValueError for an unknown link or a collision without a geometry."""
    root = ElementTree.parse(urdf_path).getroot()
    by_name = {el.get("name"): el for el in root.findall("link")}
    out = []
    for link in links:
        if link not in by_name:
            raise ValueError(f"URDF {urdf_path} has no link {link!r}")
        shapes = []
        for collision in by_name[link].findall("collision"):
            origin = collision.find("origin")
            xyz = np.array(_floats(None if origin is None else origin.get("xyz"), (0.0, 0.0, 0.0)))
            rpy = _floats(None if origin is None else origin.get("rpy"), (0.0, 0.0, 0.0))
            geometry = collision.find("geometry")
            if geometry is None or not len(geometry):
                raise ValueError(f"URDF {urdf_path}, link {link!r}: <collision> without a geometry")
            shapes.append((geometry[0], rpy_matrix(rpy), xyz))
        out.append((link, shapes))
    return out


def read_link_primitives(urdf_path: Path, links) -> list[Primitive]:
    """The collision primitives of ``links`` (in that order) of the URDF at ``urdf_path``.

    Raises ValueError for an unknown link or a geometry other than box, cylinder or sphere (a mesh:
    give the link primitive collision shapes).
    """
    out = []
    for link, shapes in collision_elements(urdf_path, links):
        for shape, rotation, origin in shapes:
            if shape.tag == "box":
                half = 0.5 * np.array([float(v) for v in shape.get("size").split()])
            elif shape.tag == "cylinder":
                half = np.array([float(shape.get("radius")), 0.5 * float(shape.get("length"))])
            elif shape.tag == "sphere":
                half = np.array([float(shape.get("radius"))])
            else:
                raise ValueError(f"URDF {urdf_path}, link {link!r}: collision geometry <{shape.tag}> is not "
                                 f"one of {', '.join(PRIMITIVE_KINDS)}; give the link primitive collision shapes")
            out.append(Primitive(link, shape.tag, half, rotation, origin))
    return out


def primitive_signed_distance_m(kind: str, half_m: np.ndarray, points_m: np.ndarray) -> np.ndarray:
    """Signed distance (negative inside) from points (..., 3), in the primitive's own frame, to the
    primitive's surface, metres."""
    p = np.asarray(points_m, float)
    if kind == "sphere":
        return np.linalg.norm(p, axis=-1) - half_m[0]
    if kind == "box":
        excess = np.abs(p) - half_m
    elif kind == "cylinder":
        excess = np.stack([np.hypot(p[..., 0], p[..., 1]) - half_m[0], np.abs(p[..., 2]) - half_m[1]], axis=-1)
    else:
        raise ValueError(f"unknown primitive kind {kind!r}; expected one of {', '.join(PRIMITIVE_KINDS)}")
    return np.linalg.norm(np.maximum(excess, 0.0), axis=-1) + np.minimum(excess.max(axis=-1), 0.0)


class ArmShapes:
    """The collision primitives of ``links`` (names of ``kinematics.link_names``), placed by the
    forward kinematics of ``kinematics`` (:class:`robots.kinematics.ArmKinematics`)."""

    def __init__(self, kinematics, links):
        self.kinematics = kinematics
        self.primitives = tuple(read_link_primitives(kinematics.spec.urdf_path, tuple(links)))
        self._rows = np.array([kinematics.link_index(p.link) for p in self.primitives], dtype=int)

    def signed_distance_m(self, q: np.ndarray, points_m: np.ndarray) -> np.ndarray:
        """(B,) smallest signed distance (negative: inside a primitive) from world points (n, 3) to
        the links at configurations ``q`` (B, dof), radians (springs at rest); +inf with no
        primitive or no point."""
        import torch

        q = np.atleast_2d(np.asarray(q, float))
        points = np.asarray(points_m, float).reshape(-1, 3)
        out = np.full(len(q), np.inf)
        if not len(points) or not self.primitives:
            return out
        with torch.no_grad():
            transforms = self.kinematics.link_transforms(torch.as_tensor(q, dtype=torch.float64)).numpy()
        for row, primitive in zip(self._rows, self.primitives):
            link_rotation, link_position = transforms[row][:, :3, :3], transforms[row][:, :3, 3]  # (B, 3, 3), (B, 3)
            rotation = link_rotation @ primitive.rotation
            centre = link_position + link_rotation @ primitive.origin_m
            local = np.einsum("bji,bnj->bni", rotation, points[None] - centre[:, None])  # (B, n, 3)
            distance = primitive_signed_distance_m(primitive.kind, primitive.half_m, local)
            out = np.minimum(out, distance.min(axis=1))
        return out
