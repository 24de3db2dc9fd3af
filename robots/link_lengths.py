"""The arm's link lengths as calibration parameters: a URDF with longer or shorter links, and the
exact shift they cause.

A link length is the translation of a joint origin between the arm's first actuated joint and its
tool (upper arm, forearm, hand; :func:`arm_link_lengths`). Lengthening link ``j`` by ``d_j`` along
its own direction ``u_j`` (parent frame) moves every frame after it rigidly by ``R_parent(q) u_j d_j``
(world) and turns none of them, so the pad of an arm with length errors ``d`` sits at

    p(q, d) = p_nominal(q) + sum_j R_parent_j(q) u_j d_j        (exact, :func:`link_length_shift_m`)

which is what a calibration fits and what :func:`with_link_length_errors` (a rewritten URDF: the
simulator's true arm, or the calibrated model) builds.
"""
from __future__ import annotations

import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Mapping

import numpy as np

from robots.spec import RobotSpec
from robots.urdf_check import read_urdf_tree

MIN_LINK_LENGTH_M = 0.01
"""Joint-origin translations shorter than this (small lateral offsets) are not counted as links."""


@dataclass(frozen=True)
class LinkLength:
    """One link length of the arm.

    Attributes
    ----------
    joint : str
        The URDF joint whose origin translation is the link.
    parent_link : str
        The joint's parent link (its frame holds the translation).
    length_m : float
        Nominal length, metres.
    direction : (3,) float
        Unit direction of the translation in the parent link's frame.
    """

    joint: str
    parent_link: str
    length_m: float
    direction: np.ndarray


def arm_link_lengths(spec: RobotSpec) -> tuple[LinkLength, ...]:
    """The arm's link lengths: joint origins of at least :data:`MIN_LINK_LENGTH_M` after the first
    actuated joint, up to and including the joint into the tool link (the fingertip is not the arm's)."""
    tree = read_urdf_tree(spec.urdf_path)
    path = tree.joints_to(spec.tool_link)
    names = [j.name for j in path]
    first = min(names.index(n) for n in spec.joint_names if n in names)
    links = []
    for joint in path[first + 1:]:
        xyz = np.asarray(joint.xyz, float)
        length = float(np.linalg.norm(xyz))
        if length >= MIN_LINK_LENGTH_M:
            links.append(LinkLength(joint.name, joint.parent, length, xyz / length))
    return tuple(links)


def _check_errors(spec: RobotSpec, errors_m: Mapping[str, float]) -> dict[str, LinkLength]:
    known = {link.joint: link for link in arm_link_lengths(spec)}
    unknown = sorted(set(errors_m) - set(known))
    if unknown:
        raise ValueError(f"{spec.name}: {unknown} are not link lengths of the arm; use {sorted(known)}")
    for name, value in errors_m.items():
        if not np.isfinite(value) or abs(value) >= 0.5 * known[name].length_m:
            raise ValueError(f"{spec.name}: link length error of {name} must be finite and below half the link "
                             f"({known[name].length_m * 1e3:.0f} mm), got {value}")
    return known


def with_link_length_errors(spec: RobotSpec, errors_m: Mapping[str, float], directory: Path) -> RobotSpec:
    """``spec`` with a URDF (written into ``directory``) whose links are longer by ``errors_m``.

    Parameters
    ----------
    errors_m : mapping joint name -> metres
        Length change of each link named (:func:`arm_link_lengths`); others stay nominal.
    directory : Path
        Where the URDF goes; it must exist as long as something still has to load it.
    """
    known = _check_errors(spec, errors_m)
    tree = ElementTree.parse(spec.urdf_path)
    for element in tree.getroot().findall("joint"):
        name = element.get("name")
        if name in errors_m and errors_m[name] != 0.0:
            link = known[name]
            xyz = (link.length_m + float(errors_m[name])) * link.direction
            element.find("origin").set("xyz", " ".join(repr(float(v)) for v in xyz))
    path = Path(directory) / f"{Path(spec.urdf_path).stem}_links.urdf"
    tree.write(path)
    return replace(spec, urdf_path=path)


def link_length_shift_m(kinematics, q, errors_m: Mapping[str, float]) -> np.ndarray:
    """World shift (n, 3) of the pad (and every frame after the links) caused by ``errors_m``.

    Parameters
    ----------
    kinematics : robots.kinematics.ArmKinematics
        The nominal model.
    q : (n, dof) float
        Joint angles, radians.
    errors_m : mapping joint name -> metres
    """
    q = np.atleast_2d(np.asarray(q, float))
    known = _check_errors(kinematics.spec, errors_m)
    shift = np.zeros((len(q), 3))
    for name, value in errors_m.items():
        if value:
            link = known[name]
            rotation = kinematics.forward_kinematics(q, link=link.parent_link).rotation
            shift += float(value) * rotation @ link.direction
    return shift
