"""The compliant tactile fingertip: sensor module on a 2-DOF spring pivot, as URDF parts.

Chain, starting at the arm's tool point (all frames coincide at zero spring angles)::

    tool --fixed--> sensor_pivot --spring_x (axis x)--> spring_gimbal --spring_y (axis y)-->
    spring_plate --fixed, +z by spring_gap + base/2--> sensor_body --fixed, +z by base/2 + pad-->
    pad

* ``sensor_pivot``: the centre of the coil spring's bend, at the tool point; +z points out of
  the hand along the approach direction.
* ``spring_x``, ``spring_y``: two perpendicular passive revolute joints through the pivot (the
  coil spring). The simulator disables their motors and applies ``-k theta - c theta_dot``.
* ``sensor_body``: the rigid base of the module (PCB with the IMU and barometer), its origin at the
  centre of that 18 x 18 x 4.0 mm layer; +z is the pad's outward face normal.
* ``pad``: frame at the centre of the outer face of the 3.7 mm polyurethane pad, axes parallel to
  ``sensor_body``; its collision box lies behind the face (-z).

The module is 18 x 18 x 7.7 mm in all (4.0 mm rigid base + 3.7 mm pad).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from robots.urdf_model import Box, Joint, Link, Shape

TOOL_LINK = "tool"
PIVOT_LINK = "sensor_pivot"
GIMBAL_LINK = "spring_gimbal"
PLATE_LINK = "spring_plate"
SENSOR_BODY_LINK = "sensor_body"
PAD_LINK = "pad"
SPRING_JOINTS = ("spring_x", "spring_y")

DEFAULT_SPRING_STIFFNESS_NM_PER_RAD = 0.02
"""Bending stiffness of the coil spring about each axis, N m/rad: gravity sags the module by
about 0.6 deg, and a 20-degree slope is fully aligned with under 2 N of contact force."""

DEFAULT_SPRING_DAMPING_NMS_PER_RAD = 4e-5
"""Spring damping, N m s/rad: damping ratio about 0.35 with the module's 1.6e-7 kg m^2 about the
pivot, and stable with the explicit spring update at 1/480 s steps (k dt^2/I + 2 c dt/I = 1.5 < 2)."""


@dataclass(frozen=True)
class FingertipGeometry:
    """Dimensions (m), masses (kg) and spring limits (rad) of the fingertip module.

    ``spring_gap_m`` is the distance from the spring's rotation centre (the pivot) to the back of
    the module; negative puts the pivot inside the module's 4 mm base. A short compression spring
    loaded off-centre turns about a point close to its end plate, and the pad can only align with
    a slope whose contact torque about the pivot turns it the right way: with the pad's half
    width ``w`` and the pivot ``d`` behind the face, an edge contact stops helping at
    ``atan(w / d)`` (46 deg with the pivot behind the module, 62 deg at 3 mm inside it).
    ``tool_to_pivot_m`` keeps the pad face where it was relative to the hand.
    """

    body_width_m: float = 0.018
    module_height_m: float = 0.0077
    pad_thickness_m: float = 0.0037
    spring_gap_m: float = -0.003
    tool_to_pivot_m: float = 0.004
    body_mass_kg: float = 0.004
    pad_mass_kg: float = 0.0012
    spring_part_mass_kg: float = 0.001
    spring_limit_rad: float = math.radians(55.0)
    spring_effort_nm: float = 1.0
    spring_velocity_rad_s: float = 30.0

    def __post_init__(self) -> None:
        if not 0.0 < self.pad_thickness_m < self.module_height_m:
            raise ValueError(
                f"pad thickness {self.pad_thickness_m} m must be positive and below the module "
                f"height {self.module_height_m} m"
            )
        if self.spring_gap_m <= -self.base_thickness_m or not 0.0 < self.spring_limit_rad < math.pi / 2:
            raise ValueError("the pivot must lie behind the pad (spring gap > -base thickness) and the "
                             "spring limit in (0, pi/2) rad")

    @property
    def base_thickness_m(self) -> float:
        """Thickness of the rigid layer under the pad, metres."""
        return self.module_height_m - self.pad_thickness_m

    @property
    def pivot_to_body_m(self) -> float:
        """Distance pivot -> sensor_body origin along +z, metres."""
        return self.spring_gap_m + self.base_thickness_m / 2.0

    @property
    def body_to_pad_m(self) -> float:
        """Distance sensor_body origin -> pad face centre along +z, metres."""
        return self.base_thickness_m / 2.0 + self.pad_thickness_m

    @property
    def pivot_to_pad_m(self) -> float:
        """Distance pivot -> pad face centre along +z, metres."""
        return self.pivot_to_body_m + self.body_to_pad_m


def fingertip_parts(tool_link: str, geometry: FingertipGeometry = FingertipGeometry()) -> tuple[
    tuple[Link, ...], tuple[Joint, ...]
]:
    """Links and joints of the fingertip, hung on ``tool_link`` (whose +z is the approach axis)."""
    g = geometry
    w = g.body_width_m
    links = (
        Link(PIVOT_LINK, g.spring_part_mass_kg),
        Link(GIMBAL_LINK, g.spring_part_mass_kg),
        Link(PLATE_LINK, g.spring_part_mass_kg),
        Link(SENSOR_BODY_LINK, g.body_mass_kg, shapes=(Shape(Box((w, w, g.base_thickness_m))),),
             rgba=(0.1, 0.4, 0.1, 1.0)),
        Link(PAD_LINK, g.pad_mass_kg, shapes=(Shape(Box((w, w, g.pad_thickness_m)),
                                                    xyz=(0.0, 0.0, -g.pad_thickness_m / 2.0)),),
             rgba=(0.9, 0.8, 0.2, 1.0)),
    )
    spring = dict(kind="revolute", lower=-g.spring_limit_rad, upper=g.spring_limit_rad,
                  effort=g.spring_effort_nm, velocity=g.spring_velocity_rad_s)
    joints = (
        Joint("tool_to_pivot", "fixed", tool_link, PIVOT_LINK, xyz=(0.0, 0.0, g.tool_to_pivot_m)),
        Joint(SPRING_JOINTS[0], parent=PIVOT_LINK, child=GIMBAL_LINK, axis=(1.0, 0.0, 0.0), **spring),
        Joint(SPRING_JOINTS[1], parent=GIMBAL_LINK, child=PLATE_LINK, axis=(0.0, 1.0, 0.0), **spring),
        Joint("plate_to_body", "fixed", PLATE_LINK, SENSOR_BODY_LINK, xyz=(0.0, 0.0, g.pivot_to_body_m)),
        Joint("body_to_pad", "fixed", SENSOR_BODY_LINK, PAD_LINK, xyz=(0.0, 0.0, g.body_to_pad_m)),
    )
    return links, joints
