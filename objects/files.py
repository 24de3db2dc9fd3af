"""Text formats written for PyBullet: Wavefront OBJ meshes and single-link static URDFs.

Written by hand rather than by trimesh's exporter so the committed files stay byte-stable across
library versions.
"""
from __future__ import annotations

import numpy as np
import trimesh

OBJ_DECIMALS = 9  # nanometres


def obj_text(mesh: trimesh.Trimesh, comment: str) -> str:
    """Wavefront OBJ text with vertices (metres, 9 decimals) and 1-based triangle faces only."""
    lines = [f"# {line}" for line in comment.splitlines()]
    lines += [f"v {x:.{OBJ_DECIMALS}f} {y:.{OBJ_DECIMALS}f} {z:.{OBJ_DECIMALS}f}" for x, y, z in np.asarray(mesh.vertices)]
    lines += [f"f {a} {b} {c}" for a, b, c in np.asarray(mesh.faces) + 1]
    return "\n".join(lines) + "\n"


def urdf_text(name: str, mesh_filename: str, rgba: tuple[float, float, float, float]) -> str:
    """URDF of one static link (mass 0) whose visual and collision geometry is ``mesh_filename``.

    ``mesh_filename`` is resolved by PyBullet relative to the URDF's folder. The link and its
    collision carry PyBullet's ``concave="yes"``: a static body then collides with the exact
    triangle mesh. Without it PyBullet uses the convex hull, which is wrong for concave objects and,
    even for convex ones, pads the surface by a 1 mm collision margin (measured with rayTest and
    getClosestPoints), a systematic error in every simulated contact position.
    """
    concave_attribute = ' concave="yes"'
    colour = " ".join(f"{c:g}" for c in rgba)
    geometry = f'<geometry><mesh filename="{mesh_filename}" scale="1 1 1"/></geometry>'
    return f"""<?xml version="1.0"?>
<!-- Static object (mass 0): PyBullet keeps it fixed. Units: metres. -->
<robot name="{name}">
  <link name="{name}"{concave_attribute}>
    <inertial>
      <origin xyz="0 0 0" rpy="0 0 0"/>
      <mass value="0"/>
      <inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/>
    </inertial>
    <visual>
      <origin xyz="0 0 0" rpy="0 0 0"/>
      {geometry}
      <material name="{name}_colour"><color rgba="{colour}"/></material>
    </visual>
    <collision{concave_attribute}>
      <origin xyz="0 0 0" rpy="0 0 0"/>
      {geometry}
    </collision>
  </link>
</robot>
"""
