"""The arm's collision shapes as spheres, for planning motions clear of an obstacle.

Each URDF collision primitive of a link is covered by a few spheres (a cylinder or a box by a row
of spheres along its longest axis, a sphere by itself), in the link's frame; forward kinematics of
a batch of configurations then places every sphere in the world at once. Spheres, not the exact
primitives, because a sphere's distance to a box is one line of numpy and a planner asks it for
thousands of configurations; every sphere contains its part of the primitive, so "the spheres are
clear" implies "the arm is clear" (a conservative test).
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from robots.link_shapes import collision_elements


@dataclass(frozen=True)
class LinkSpheres:
    """Spheres covering one link's collision shapes.

    Attributes
    ----------
    link : str
    centres_m : (k, 3) float
        Sphere centres, link frame, metres.
    radii_m : (k,) float
        Sphere radii, metres.
    """

    link: str
    centres_m: np.ndarray
    radii_m: np.ndarray


def _row_of_spheres(length_m: float, cross_radius_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Spheres along z covering a segment of ``length_m`` whose cross-section fits in a circle of
    ``cross_radius_m``: (n,) z-centres and the common radius (covers each 1/n of the segment)."""
    n = max(1, math.ceil(length_m / max(cross_radius_m, 1e-6)))
    half_piece = 0.5 * length_m / n
    z = -0.5 * length_m + half_piece * (2 * np.arange(n) + 1)
    return z, math.hypot(cross_radius_m, half_piece)


def _primitive_spheres(geometry: ElementTree.Element, where: str) -> tuple[np.ndarray, np.ndarray]:
    """(k, 3) centres and (k,) radii covering one primitive, in its own frame."""
    if geometry.tag == "sphere":
        return np.zeros((1, 3)), np.array([float(geometry.get("radius"))])
    if geometry.tag == "cylinder":
        radius, length = float(geometry.get("radius")), float(geometry.get("length"))
        z, r = _row_of_spheres(length, radius)
        return np.column_stack([np.zeros_like(z), np.zeros_like(z), z]), np.full(len(z), r)
    if geometry.tag == "box":
        size = np.array([float(v) for v in geometry.get("size").split()])
        axis = int(np.argmax(size))
        others = [i for i in range(3) if i != axis]
        z, r = _row_of_spheres(float(size[axis]), 0.5 * float(np.hypot(*size[others])))
        centres = np.zeros((len(z), 3))
        centres[:, axis] = z
        return centres, np.full(len(z), r)
    raise ValueError(f"{where}: collision geometry <{geometry.tag}> is not supported by the sphere model "
                     "(box, cylinder, sphere); give the link primitive collision shapes")


def read_link_spheres(urdf_path: Path, links: tuple[str, ...] | list[str]) -> list[LinkSpheres]:
    """Spheres covering the collision shapes of ``links`` (in that order) of the URDF at ``urdf_path``.

    A link without collision shapes gets no spheres (an empty :class:`LinkSpheres`).
    """
    out = []
    for link, shapes in collision_elements(urdf_path, links):
        centres, radii = [np.zeros((0, 3))], [np.zeros(0)]
        for geometry, rotation, origin in shapes:
            c, r = _primitive_spheres(geometry, f"URDF {urdf_path}, link {link!r}")
            centres.append(c @ rotation.T + origin)
            radii.append(r)
        out.append(LinkSpheres(link, np.vstack(centres), np.concatenate(radii)))
    return out


class ArmSpheres:
    """The spheres of a chain of links placed by forward kinematics.

    Parameters
    ----------
    kinematics : robots.kinematics.ArmKinematics
    links : sequence of str
        Links of ``kinematics.link_names`` to cover.
    """

    def __init__(self, kinematics, links):
        self.kinematics = kinematics
        parts = read_link_spheres(kinematics.spec.urdf_path, tuple(links))
        self._rows = np.array([kinematics.link_index(p.link) for p in parts for _ in p.radii_m], dtype=int)
        self._local = np.vstack([p.centres_m for p in parts]) if parts else np.zeros((0, 3))
        self.radii_m = np.concatenate([p.radii_m for p in parts]) if parts else np.zeros(0)
        self.link_of_sphere = tuple(p.link for p in parts for _ in p.radii_m)

    def centres_m(self, q: np.ndarray) -> np.ndarray:
        """(B, k, 3) world sphere centres for configurations ``q`` (B, dof), radians (springs at rest)."""
        import torch

        q = np.atleast_2d(np.asarray(q, float))
        with torch.no_grad():
            transforms = self.kinematics.link_transforms(torch.as_tensor(q, dtype=torch.float64)).numpy()
        placed = transforms[self._rows]  # (k, B, 4, 4)
        return np.einsum("kbij,kj->bki", placed[:, :, :3, :3], self._local) + placed[:, :, :3, 3].transpose(1, 0, 2)

    def subset(self, keep: np.ndarray) -> "ArmSpheres":
        """The spheres where ``keep`` ((k,) bool) is true."""
        keep = np.asarray(keep, bool)
        out = object.__new__(ArmSpheres)
        out.kinematics = self.kinematics
        out._rows, out._local, out.radii_m = self._rows[keep], self._local[keep], self.radii_m[keep]
        out.link_of_sphere = tuple(name for name, k in zip(self.link_of_sphere, keep) if k)
        return out
