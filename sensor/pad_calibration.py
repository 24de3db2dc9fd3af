"""What a contact measurement needs to know about one fingertip's pad.

Three things turn the raw readings of a press into a force and a surface point: the pad's
pressure-to-force curve, how far the pad face sinks in per newton, and how the IMU is mounted.
In simulation they are the simulated pad's own parameters; on hardware they come from the
sensor's calibration (:meth:`sensor.calibration.SensorCalibration.pad_calibration`). Whoever
builds a rig builds one :class:`PadCalibration` and hands it down; nothing reads a module default.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from sensor.normal_estimation import ImuAlignment
from sensor.sim.pad_response import PadResponse

#: Contact stiffness of the 3.7 mm polyurethane pad: a soft cast pad (shore 00, about 0.04 MPa)
#: over the 18 x 18 mm face compresses about 0.3 mm per newton (the nominal compliance below).
#: The simulation uses it as PyBullet's stiffness per contact point, and the simulated face then
#: compresses 0.136 mm/N: its scenes measure that (``robots.pad_compliance``) instead.
PAD_STIFFNESS_N_PER_M = 3.0e3
#: Bending stiffness of the fingertip's coil spring per axis, N m/rad (the value of
#: ``robots.fingertip.DEFAULT_SPRING_STIFFNESS_NM_PER_RAD``; sensor does not import robots).
SPRING_STIFFNESS_NM_PER_RAD = 0.02
#: Half the side of the square 18 x 18 mm pad face, metres.
PAD_HALF_WIDTH_M = 0.009


class PadForceModel(Protocol):
    """Pressure rise -> normal force (``sensor.sim.pad_response.PadResponse`` is one)."""

    def force_n(self, pressure_rise_pa): ...

    def force_estimate_n(self, pressure_rise_pa: float) -> float: ...


@dataclass(frozen=True)
class PadCalibration:
    """The pad's force model, compliance and IMU mounting.

    Attributes
    ----------
    force_model : PadForceModel
        Inverted for the force of a press (``force_n``) and to end a press at its target force
        (``force_estimate_n``).
    compliance_m_per_n : float
        Pad compression per newton: a contact's pad face is ``force x compliance`` inside the
        surface, so the surface point is moved back out by that, metres per newton.
    alignment : ImuAlignment
        How the IMU quaternion maps to the pad's orientation (identity in simulation).
    spring_stiffness_nm_per_rad : float
        Bending stiffness of the spring the pad turns on, per axis, N m/rad: the spring's deflection
        times this is the contact's torque about the pivot, which says where on the pad it pressed.
    half_width_m : float
        Half the side of the square pad face, metres.
    point_compliance_m_per_n : float or None
        Pad compression per newton where the face bears on one point (pressed head on onto a small
        ball), metres per newton: larger than ``compliance_m_per_n``, which a flat plate gives; used
        where the surface curves away from the pad in every direction
        (:mod:`explorer.pad_indentation`). None: not measured, no such correction.
    """

    force_model: PadForceModel = field(default_factory=PadResponse)
    compliance_m_per_n: float = 1.0 / PAD_STIFFNESS_N_PER_M
    alignment: ImuAlignment = field(default_factory=ImuAlignment)
    spring_stiffness_nm_per_rad: float = SPRING_STIFFNESS_NM_PER_RAD
    half_width_m: float = PAD_HALF_WIDTH_M
    point_compliance_m_per_n: float | None = None

    def __post_init__(self):
        if not (np.isfinite(self.compliance_m_per_n) and self.compliance_m_per_n >= 0.0):
            raise ValueError(f"compliance_m_per_n must be finite and >= 0, got {self.compliance_m_per_n}")
        point = self.point_compliance_m_per_n
        if point is not None and not (np.isfinite(point) and point >= 0.0):
            raise ValueError(f"point_compliance_m_per_n must be finite and >= 0 (or None: not measured), got {point}")
        for name in ("spring_stiffness_nm_per_rad", "half_width_m"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} must be finite and > 0, got {value}")

    def surface_point(self, pad_face_m: np.ndarray, normal: np.ndarray, force_n: float) -> np.ndarray:
        """(3,) surface point: the pad face moved out along the outward ``normal`` by the compression."""
        return pad_face_m + normal * force_n * self.compliance_m_per_n

    def as_dict(self) -> dict:
        """Plain values for the session metadata (read back by :meth:`from_dict`)."""
        model = self.force_model
        force = {name: float(getattr(model, name)) for name in ("saturation_pa", "force_scale_n",
                                                               "lag_time_constant_s") if hasattr(model, name)}
        return dict(compliance_m_per_n=float(self.compliance_m_per_n), force_model=force,
                    body_in_imu_wxyz=[float(v) for v in self.alignment.body_in_imu_wxyz],
                    reference_in_world_wxyz=[float(v) for v in self.alignment.reference_in_world_wxyz],
                    spring_stiffness_nm_per_rad=float(self.spring_stiffness_nm_per_rad),
                    half_width_m=float(self.half_width_m),
                    point_compliance_m_per_n=None if self.point_compliance_m_per_n is None
                    else float(self.point_compliance_m_per_n))

    @classmethod
    def from_dict(cls, data: dict) -> "PadCalibration":
        """The calibration :meth:`as_dict` wrote (missing entries take the nominal pad's values; a
        missing point compliance is not measured)."""
        nominal = cls()
        alignment = ImuAlignment(
            tuple(float(v) for v in data.get("body_in_imu_wxyz", nominal.alignment.body_in_imu_wxyz)),
            tuple(float(v) for v in data.get("reference_in_world_wxyz", nominal.alignment.reference_in_world_wxyz)))
        return cls(PadResponse(**data.get("force_model", {})),
                   float(data.get("compliance_m_per_n", nominal.compliance_m_per_n)), alignment,
                   float(data.get("spring_stiffness_nm_per_rad", nominal.spring_stiffness_nm_per_rad)),
                   float(data.get("half_width_m", nominal.half_width_m)),
                   None if data.get("point_compliance_m_per_n") is None else float(data["point_compliance_m_per_n"]))
