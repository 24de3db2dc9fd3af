"""Read a URDF's kinematic tree and check that it carries the fingertip a RobotSpec names."""
from __future__ import annotations

import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from robots.spec import RobotSpec

MOVABLE_KINDS = ("revolute", "continuous")


@dataclass(frozen=True)
class UrdfJoint:
    """A joint as written in the URDF (lengths in metres, limits in radians; +/-inf if none)."""

    name: str
    kind: str
    parent: str
    child: str
    xyz: tuple[float, float, float]
    axis: tuple[float, float, float]
    lower_rad: float
    upper_rad: float


@dataclass(frozen=True)
class UrdfTree:
    """The link/joint tree of one URDF file."""

    path: Path
    root_link: str
    links: tuple[str, ...]
    joints: tuple[UrdfJoint, ...]

    def joint(self, name: str) -> UrdfJoint:
        for joint in self.joints:
            if joint.name == name:
                return joint
        raise KeyError(name)

    def joints_to(self, link: str) -> list[UrdfJoint]:
        """Joints on the path from the root link to ``link``, root side first."""
        by_child = {j.child: j for j in self.joints}
        path = []
        while link != self.root_link:
            joint = by_child[link]
            path.append(joint)
            link = joint.parent
        return path[::-1]


def _floats(text: str | None, default: tuple[float, ...]) -> tuple[float, ...]:
    return default if text is None else tuple(float(v) for v in text.split())


def read_urdf_tree(path: Path) -> UrdfTree:
    """Parse ``path``; a missing file, bad XML or a non-tree structure gives a clear error."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"URDF file not found: {path}")
    try:
        root = ElementTree.parse(path).getroot()
    except ElementTree.ParseError as err:
        raise ValueError(f"URDF {path} is not valid XML: {err}") from None
    if root.tag != "robot":
        raise ValueError(f"URDF {path}: top element is <{root.tag}>, expected <robot>")
    links = tuple(el.get("name") for el in root.findall("link"))
    joints = []
    for el in root.findall("joint"):
        parent, child = el.find("parent"), el.find("child")
        if parent is None or child is None:
            raise ValueError(f"URDF {path}: joint {el.get('name')!r} lacks <parent> or <child>")
        origin = el.find("origin")
        axis = el.find("axis")
        limit = el.find("limit")
        kind = el.get("type", "")
        lower, upper = -np.inf, np.inf
        if kind == "revolute" and limit is not None:
            lower, upper = float(limit.get("lower", "0")), float(limit.get("upper", "0"))
        joints.append(UrdfJoint(
            name=el.get("name"), kind=kind, parent=parent.get("link"), child=child.get("link"),
            xyz=_floats(None if origin is None else origin.get("xyz"), (0.0, 0.0, 0.0)),
            axis=_floats(None if axis is None else axis.get("xyz"), (1.0, 0.0, 0.0)),
            lower_rad=lower, upper_rad=upper,
        ))
    children = [j.child for j in joints]
    roots = sorted(set(links) - set(children))
    if len(roots) != 1 or len(set(children)) != len(children):
        raise ValueError(f"URDF {path} is not a single tree of links (root candidates: {roots})")
    return UrdfTree(path, roots[0], links, tuple(joints))


def check_spec_against_urdf(spec: RobotSpec) -> UrdfTree:
    """Check that ``spec``'s URDF holds every named joint and link in the right arrangement.

    Raises
    ------
    ValueError
        Naming every missing joint/link and every misplaced one.
    """
    tree = read_urdf_tree(spec.urdf_path)
    joint_names = {j.name for j in tree.joints}
    link_roles = {
        "tool_link": spec.tool_link,
        "pivot_link": spec.pivot_link,
        "sensor_body_link": spec.sensor_body_link,
        "pad_link": spec.pad_link,
    }
    missing_joints = [n for n in spec.joint_names + spec.spring_joint_names if n not in joint_names]
    missing_links = [f"{role}={name!r}" for role, name in link_roles.items() if name not in tree.links]
    if missing_joints or missing_links:
        parts = []
        if missing_joints:
            parts.append(f"joints {missing_joints}")
        if missing_links:
            parts.append(f"links {missing_links}")
        raise ValueError(
            f"URDF {spec.urdf_path} lacks the fingertip/arm parts robot spec {spec.name!r} names: "
            + " and ".join(parts)
        )
    problems = []
    to_pad = [j.name for j in tree.joints_to(spec.pad_link)]
    for name in spec.joint_names + spec.spring_joint_names:
        if tree.joint(name).kind not in MOVABLE_KINDS:
            problems.append(f"joint {name!r} is {tree.joint(name).kind!r}, expected revolute")
        if name not in to_pad:
            problems.append(f"joint {name!r} is not on the chain from {tree.root_link!r} to the pad")
    to_pivot = [j.name for j in tree.joints_to(spec.pivot_link)]
    spring_x, spring_y = (tree.joint(n) for n in spec.spring_joint_names)
    if spring_x.parent != spec.pivot_link:
        problems.append(f"spring joint {spring_x.name!r} must have the pivot link {spec.pivot_link!r} as parent")
    if spring_y.parent != spring_x.child:
        problems.append(f"spring joint {spring_y.name!r} must follow {spring_x.name!r} directly")
    if any(abs(v) > 1e-12 for v in spring_x.xyz + spring_y.xyz):
        problems.append("spring joint origins must be at the pivot (xyz = 0 0 0) so their axes meet there")
    for name in spec.joint_names:
        if name in to_pad and name not in to_pivot:
            problems.append(f"actuated joint {name!r} lies beyond the pivot")
    beyond_pivot = [j for j in tree.joints_to(spec.pad_link) if j.name not in to_pivot]
    extra = [j.name for j in beyond_pivot if j.kind != "fixed" and j.name not in spec.spring_joint_names]
    extra += [j.name for j in tree.joints_to(spec.pivot_link)
              if j.kind != "fixed" and j.name not in spec.joint_names]
    if extra:
        problems.append(f"movable joints {extra} on the chain to the pad are neither actuated nor springs")
    body_chain = [j.name for j in tree.joints_to(spec.sensor_body_link)]
    if spring_y.name not in body_chain:
        problems.append(f"sensor body link {spec.sensor_body_link!r} is not carried by the spring joints")
    pad_chain_links = [j.child for j in tree.joints_to(spec.pad_link)]
    if spec.pad_link != spec.sensor_body_link and spec.sensor_body_link not in pad_chain_links:
        problems.append(f"pad link {spec.pad_link!r} is not attached to the sensor body {spec.sensor_body_link!r}")
    if spec.tool_link not in [tree.root_link] + [j.child for j in tree.joints_to(spec.pivot_link)]:
        problems.append(f"tool link {spec.tool_link!r} is not on the chain to the pivot")
    if problems:
        raise ValueError(f"URDF {spec.urdf_path} does not fit robot spec {spec.name!r}: " + "; ".join(problems))
    for name, q in zip(spec.joint_names, spec.home_q_rad):
        joint = tree.joint(name)
        if not joint.lower_rad - 1e-9 <= q <= joint.upper_rad + 1e-9:
            raise ValueError(
                f"robot spec {spec.name!r}: home position {q:.4f} rad of joint {name!r} is outside its "
                f"limits [{joint.lower_rad:.4f}, {joint.upper_rad:.4f}]"
            )
    return tree
