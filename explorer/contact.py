"""One contact pipeline: a press's readings, the arm's joint state, the stand pose and the pad's
calibration -> a contact in the object frame, with its quality.

The exploration loop, teleoperation and the offline replay all measure contacts here, so a change
to how a contact is measured (the pad model, the settling test, the compliance correction) is made
once. The steps:

1. the spring pivot from the forward kinematics of the encoder readings ``q``;
2. :func:`sensor.normal_estimation.oriented_contact`: the settled IMU orientation gives the normal,
   the pad's force model the force, the pivot plus the rotated pivot-to-pad offset the pad face;
3. the pad compression (force x compliance) added back along the normal: the surface point;
4. the stand pose carries point and normal into the object frame.

The realign rule (:func:`misaligned`) is here too: the loop applies it live and replay applies it
the same way.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from explorer.positioner import Positioner, StandPose, stand_rotation
from sensor.normal_estimation import OrientationNotSettledError, SettlingConfig, estimate_normal, oriented_contact
from sensor.oriented_contact import OrientedContact
from sensor.pad_calibration import PadCalibration
from sensor.reading import Reading

#: The loop's settling test: the orientation within 0.5 deg over 0.15 s (IMU noise is ~0.1 deg).
LOOP_SETTLING = SettlingConfig(settle_window_s=0.15, max_deviation_rad=float(np.radians(0.5)))


class NoContactMeasured(ValueError):
    """The press's readings give no contact: the orientation never settled, or the pressure saturated."""


@dataclass(frozen=True)
class ObjectFrame:
    """Where the object frame is in the world: ``x_world = rotation @ x_object + origin_m``.

    Attributes
    ----------
    rotation : (3, 3) float
    origin_m : (3,) float
        World position of the object-frame origin, metres.
    pose : StandPose
        The stand angles that give ``rotation``.
    """

    rotation: np.ndarray
    origin_m: np.ndarray
    pose: StandPose = StandPose()

    @classmethod
    def of_positioner(cls, positioner: Positioner) -> "ObjectFrame":
        """The frame at the positioner's current pose."""
        rotation, origin = positioner.object_to_world()
        return cls(rotation, origin, positioner.pose())

    @classmethod
    def of_stand(cls, centre_m, yaw_rad: float, tilt_rad: float) -> "ObjectFrame":
        """The frame of a stand at ``centre_m`` turned to ``yaw_rad``, ``tilt_rad`` (a recorded touch)."""
        pose = StandPose(yaw_rad, tilt_rad)
        return cls(stand_rotation(pose), np.asarray(centre_m, float), pose)

    def to_object(self, points_world: np.ndarray, directions_world: np.ndarray | None = None):
        """World points (n, 3) (and directions) in the object frame (as ``Positioner.to_object``)."""
        points = (np.asarray(points_world, float) - self.origin_m) @ self.rotation
        if directions_world is None:
            return points
        return points, np.asarray(directions_world, float) @ self.rotation


@dataclass(frozen=True)
class ContactQuality:
    """How far a contact can be trusted.

    Attributes
    ----------
    force_n : float
        Estimated normal force, newtons.
    n_readings : int
        Readings the contact was measured from.
    approach_cosine : float or None
        Cosine of the angle between the outward normal and the reversed approach direction (1: the
        pad met the surface head on); None when the approach is not known.
    """

    force_n: float
    n_readings: int
    approach_cosine: float | None = None

    @property
    def approach_angle_rad(self) -> float | None:
        """Angle between the measured normal and the approach, radians."""
        if self.approach_cosine is None:
            return None
        return float(np.arccos(np.clip(self.approach_cosine, -1.0, 1.0)))


@dataclass(frozen=True)
class MeasuredContact:
    """A contact, in the world as measured and in the object frame.

    Attributes
    ----------
    world : OrientedContact
        Pad-face centre, normal, force, time and readings, world frame.
    position_m : (3,) float
        Surface point (pad compression added back), object frame, metres.
    normal : (3,) float
        Outward unit normal, object frame.
    quality : ContactQuality
    """

    world: OrientedContact
    position_m: np.ndarray
    normal: np.ndarray
    quality: ContactQuality


def misaligned(normal: np.ndarray, approach_dir: np.ndarray, realign_angle_rad: float) -> bool:
    """The realign rule: the outward ``normal`` is more than ``realign_angle_rad`` from ``-approach_dir``.

    The pad may then have stuck part way (see ``LoopConfig.realign_angle_rad``).
    """
    return float(np.dot(normal, -approach_dir)) < np.cos(realign_angle_rad)


class ContactPipeline:
    """Measures contacts of one arm and pad.

    Parameters
    ----------
    kinematics : robots.kinematics.ArmKinematics
        The arm's kinematics (spring pivot link and pivot-to-pad offset).
    pad : PadCalibration
        The sensor's pad: force model, compliance, IMU mounting.
    settling : SettlingConfig
        When the orientation counts as settled.
    """

    def __init__(self, kinematics, pad: PadCalibration, settling: SettlingConfig = LOOP_SETTLING):
        self.kinematics = kinematics
        self.pad = pad
        self.settling = settling

    def measure(self, readings: Sequence[Reading], baseline_pa: float, q: np.ndarray, frame: ObjectFrame,
                approach_dir: np.ndarray | None = None) -> MeasuredContact:
        """The contact of one press.

        Parameters
        ----------
        readings : sequence of Reading
            The press's readings from the detected start on, in time order.
        baseline_pa : float
            The detector's free-pad pressure at the start, pascals.
        q : (dof,) float
            Encoder joint positions while the pad rests in contact, radians.
        frame : ObjectFrame
            The object frame during the press.
        approach_dir : (3,) float, optional
            Direction the pad travelled, object frame (for :attr:`ContactQuality.approach_cosine`).

        Raises
        ------
        NoContactMeasured
            The orientation never settled, or the pressure saturated.
        """
        kin = self.kinematics
        pivot = kin.forward_kinematics(q, link=kin.spec.pivot_link).position_m
        try:
            contact = oriented_contact(readings, pivot, kin.pivot_to_pad_in_body, baseline_pa,
                                       pad=self.pad.force_model, settling=self.settling,
                                       alignment=self.pad.alignment)
        except (OrientationNotSettledError, ValueError) as err:  # ValueError: saturated, too few readings
            raise NoContactMeasured(str(err)) from err
        surface = self.pad.surface_point(contact.position_m, contact.normal, contact.force_n)
        p_obj, n_obj = frame.to_object(surface[None], contact.normal[None])
        normal = n_obj[0] / np.linalg.norm(n_obj[0])
        cosine = None if approach_dir is None else float(np.dot(normal, -np.asarray(approach_dir, float)))
        return MeasuredContact(contact, p_obj[0], normal, ContactQuality(contact.force_n, len(readings), cosine))

    def force_estimate_n(self, pressure_rise_pa: float) -> float:
        """Force for a pressure rise over the baseline (clipped into the model's range), newtons."""
        return self.pad.force_model.force_estimate_n(pressure_rise_pa)

    def settled(self, readings: Sequence[Reading], baseline_pa: float) -> bool:
        """The orientation over the latest settling window of ``readings`` is steady."""
        window = self.settling.settle_window_s
        if not readings or readings[-1].t_s - readings[0].t_s < window:
            return False
        recent = [r for r in readings if r.t_s >= readings[-1].t_s - window]
        try:
            estimate_normal(recent, baseline_pa, pad=self.pad.force_model, settling=self.settling,
                            alignment=self.pad.alignment)
        except (OrientationNotSettledError, ValueError):
            return False
        return True
