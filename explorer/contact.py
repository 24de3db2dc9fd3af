"""One contact pipeline: a press's readings, the arm's joint state, the stand pose and the pad's
calibration -> a contact in the object frame, with its quality.

The exploration loop, teleoperation and the offline replay all measure contacts here, so a change
to how a contact is measured (the pad model, the settling test, the compliance correction) is made
once. The steps:

1. the spring pivot from the forward kinematics of the encoder readings ``q``;
2. :func:`sensor.normal_estimation.oriented_contact`: the settled IMU orientation gives the normal,
   the pad's force model the force, the pivot plus the rotated pivot-to-pad offset the pad face;
3. the centre of pressure on the pad face from the spring's deflection (:func:`pad_load`, issue
   11): where the pad rests on its rim, an edge or a ridge, the contact is there, not at the
   face centre;
4. the pad compression (force x compliance) added back along the normal: the surface point;
5. the stand pose carries point and normal into the object frame;
6. the quality: :class:`DoubtRule` marks a doubtful normal (the pad on its rim) and, in the loop,
   a press on the pad's side (no contact).

The realign rule (:func:`wants_realign`) is here too: the loop applies it live and replay applies
it the same way.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
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


class PadSideContact(NoContactMeasured):
    """The press never reached the side-contact force with the pad hardly turned
    (:meth:`DoubtRule.side_contact`): the object met the pad's side or corner, not its face."""


class PressReleased(NoContactMeasured):
    """The pad had let go before its orientation settled: the settled force lies below the contact
    detector's end threshold, so by the detector's own rule the contact was over. Neither the pad's
    orientation nor its place says where the surface is (e.g. the arm's protective stop pulled the
    pad back while it pressed on its side: 0.06 N settled after a 1.6 N peak, 24 mm off the mug)."""


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
    tilt_rad : float or None
        Spring deflection: angle between the pad's face axis and the tool axis, radians.
    pad_uv_m : (float, float) or None
        Centre of pressure on the pad face from the spring's deflection (:class:`PadLoad`), along
        the pad's x and y axes, metres (unclipped).
    rim_distance_m : float or None
        How far inside the pad's square that centre lies, metres; near zero or negative the pad
        rests on its rim (an edge, a ridge, or friction holding it part way).
    doubtful : bool
        The normal may be off (:class:`DoubtRule`): the GPIS takes it with a larger noise.
    peak_force_n : float or None
        The largest force of the press (from its highest pressure reading), newtons; ``force_n``
        is the settled one, which a creeping or cooling pad reads lower. None: not known.
    loosely_settled : bool
        The orientation never passed the settling test, only the pipeline's looser fallback
        (``ContactPipeline.loose_settling``): the pad still rocked by up to that angle, so the
        normal is doubtful.
    """

    force_n: float
    n_readings: int
    approach_cosine: float | None = None
    tilt_rad: float | None = None
    pad_uv_m: tuple[float, float] | None = None
    rim_distance_m: float | None = None
    doubtful: bool = False
    peak_force_n: float | None = None
    loosely_settled: bool = False

    @property
    def approach_angle_rad(self) -> float | None:
        """Angle between the measured normal and the approach, radians."""
        if self.approach_cosine is None:
            return None
        return float(np.arccos(np.clip(self.approach_cosine, -1.0, 1.0)))


@dataclass(frozen=True)
class PadLoad:
    """Where on the pad face the contact pressed, from the spring's deflection (world frame).

    The spring is a two-axis gimbal at the pivot (``spring_x`` then ``spring_y``, see
    ``robots/fingertip.py``); the encoders give the pivot frame, the IMU the pad's normal, so the two
    spring angles follow. In equilibrium the contact force ``F n`` (``n`` the outward normal, the
    force pushing the pad back) at the pad point ``s`` off the face centre holds the spring's torque:
    ``F (s x n) . axis_i = k angle_i`` for both axes, two equations for the two in-plane components
    of ``s``. Friction at the contact and gravity on the module are left out (they move ``s`` by at
    most the pivot depth times the friction coefficient).

    Attributes
    ----------
    offset_m : (3,) float
        ``s``: from the pad-face centre to the centre of pressure, in the face plane, world frame,
        metres, clipped to the pad's square.
    pad_uv_m : (2,) float
        ``s`` along the pad's x and y axes before clipping, metres.
    spring_angles_rad : (2,) float
        Spring deflection about the two gimbal axes, radians.
    """

    offset_m: np.ndarray
    pad_uv_m: np.ndarray
    spring_angles_rad: np.ndarray

    @property
    def tilt_rad(self) -> float:
        """Angle between the pad's face axis and the tool's, radians."""
        a, b = self.spring_angles_rad
        return float(np.arccos(np.clip(np.cos(a) * np.cos(b), -1.0, 1.0)))

    def rim_distance_m(self, half_width_m: float) -> float:
        """How far the centre of pressure lies inside the pad's square face (negative: outside), metres."""
        return float(half_width_m - np.max(np.abs(self.pad_uv_m)))


def pad_load(pivot_rotation: np.ndarray, normal: np.ndarray, force_n: float, stiffness_nm_per_rad: float,
             half_width_m: float) -> PadLoad:
    """The centre of pressure on the pad from the spring's deflection (:class:`PadLoad`).

    Parameters
    ----------
    pivot_rotation : (3, 3) float
        Pivot frame -> world (forward kinematics of the encoders); its +z is the tool axis.
    normal : (3,) float
        Measured outward surface normal, world frame (minus the pad's face axis).
    force_n : float
        Contact force, newtons (> 0).
    stiffness_nm_per_rad, half_width_m : float
        The spring's stiffness per axis and the pad's half side.
    """
    pivot_rotation = np.asarray(pivot_rotation, float)
    normal = np.asarray(normal, float) / np.linalg.norm(normal)
    z = pivot_rotation.T @ -normal  # the pad's face axis in the pivot frame = Rx(a) Ry(b) e_z
    b = float(np.arcsin(np.clip(z[0], -1.0, 1.0)))
    a = float(np.arctan2(-z[1], z[2]))
    ca, sa, cb, sb = np.cos(a), np.sin(a), np.cos(b), np.sin(b)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, ca, -sa], [0.0, sa, ca]])
    ry = np.array([[cb, 0.0, sb], [0.0, 1.0, 0.0], [-sb, 0.0, cb]])
    body = pivot_rotation @ rx @ ry
    axes = (pivot_rotation[:, 0], pivot_rotation @ rx[:, 1])
    force = max(float(force_n), 1e-6)
    matrix = np.array([[force * np.dot(np.cross(body[:, j], normal), axis) for j in (0, 1)] for axis in axes])
    uv = np.linalg.solve(matrix, stiffness_nm_per_rad * np.array([a, b]))
    clipped = np.clip(uv, -half_width_m, half_width_m)
    return PadLoad(body[:, :2] @ clipped, uv, np.array([a, b]))


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


@dataclass(frozen=True)
class DoubtRule:
    """When a contact's normal is doubtful, from what the loop has on hardware too (issue 11).

    The pad's normal is the surface's only where the pad lies flat on it. Where it rests on its
    rim (on an edge or a ridge, or held part way round by friction on a slope) the spring's
    deflection puts the centre of pressure near the rim of the face (:class:`PadLoad`), and the
    normal is off by up to the angle the pad still had to turn. Thresholds chosen on the tuning
    split of the generated objects (BENCHMARKS.md, issue 11).

    Attributes
    ----------
    rim_margin_m : float
        Doubtful when the centre of pressure lies less than this inside the pad's square, metres.
    approach_angle_rad : float
        ... and the measured normal is more than this from the approach (a pad pressed head on
        does not lean on its rim by friction), radians.
    side_force_n : float or None
        A press that never reached this force (its peak, :attr:`ContactQuality.peak_force_n`, or
        the settled force where the peak is not known) with the pad turned less than
        ``side_tilt_rad`` is no contact of the pad's face: the press ran to its depth without the
        force and the pad did not yield by turning, so it was pushed aside (the object met the pad's side or
        corner; its centre can be more than the pad's half width off). The pipeline then raises
        :class:`NoContactMeasured`. None (default, e.g. teleoperation, where the operator sets
        the force): no such test; the loop sets it from its press force.
    side_tilt_rad : float
        See ``side_force_n``, radians.
    """

    rim_margin_m: float = 0.006
    approach_angle_rad: float = float(np.radians(10.0))
    side_force_n: float | None = None
    side_tilt_rad: float = float(np.radians(12.0))

    def side_contact(self, quality: "ContactQuality") -> bool:
        """Whether ``quality`` marks a press on the pad's side (see ``side_force_n``)."""
        if self.side_force_n is None or quality.tilt_rad is None:
            return False
        # The peak, not the settled force: a pad that creeps or cools after the press stopped on
        # force reads less while the IMU settles (hardware-like profile: 1.5 N -> 1.1-1.2 N).
        force = quality.force_n if quality.peak_force_n is None else max(quality.force_n, quality.peak_force_n)
        return bool(force < self.side_force_n and quality.tilt_rad < self.side_tilt_rad)

    def doubtful(self, quality: "ContactQuality") -> bool:
        """Whether ``quality`` (loosely settled, or with ``rim_distance_m``) marks a doubtful normal."""
        if quality.loosely_settled:
            return True
        if quality.rim_distance_m is None:
            return False
        leaning = quality.approach_cosine is None or quality.approach_cosine < np.cos(self.approach_angle_rad)
        return bool(quality.rim_distance_m < self.rim_margin_m and leaning)


def wants_realign(quality: "ContactQuality", normal: np.ndarray, approach_dir: np.ndarray,
                  realign_angle_rad: float, realigns_so_far: int, max_realigns: int) -> bool:
    """The realign rule (issue 11): set the contact aside and repeat it along its normal only when
    it is doubtful, misaligned by more than ``realign_angle_rad`` and the realign budget
    (``max_realigns`` touches) is not spent. Otherwise a doubtful contact is used with a larger
    normal noise. ``quality`` None (no pad-load estimate): the plain angle rule."""
    if realigns_so_far >= max_realigns or not misaligned(normal, approach_dir, realign_angle_rad):
        return False
    return quality is None or bool(getattr(quality, "doubtful", True))


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
    loose_settling : SettlingConfig, optional
        A press that never passes ``settling`` is measured with this looser test instead (a contact
        marked ``loosely_settled``, hence doubtful) before it counts as no contact. The pad of a
        press on a rim or in a curved hollow can rock by a degree for the whole hold while it
        rests where it touched (:meth:`explorer.loop.LoopConfig.loose_settling`). None: no fallback.
    centre_of_pressure : bool
        Place the contact at the centre of pressure the spring's deflection gives (:func:`pad_load`)
        instead of the pad-face centre (False: the pipeline before issue 11, for comparison).
    doubt : DoubtRule, optional
        When a contact is doubtful (default :class:`DoubtRule`).
    release_threshold_pa : float, optional
        The contact detector's end threshold (pressure rise over the baseline, pascals): a press
        whose settled force is below its force had let go (:class:`PressReleased`). None: no such test.
    """

    def __init__(self, kinematics, pad: PadCalibration, settling: SettlingConfig = LOOP_SETTLING,
                 centre_of_pressure: bool = True, doubt: DoubtRule | None = None,
                 release_threshold_pa: float | None = None, loose_settling: SettlingConfig | None = None):
        if release_threshold_pa is not None and not (np.isfinite(release_threshold_pa) and release_threshold_pa > 0):
            raise ValueError(f"release_threshold_pa must be None or a positive pressure, got {release_threshold_pa!r}")
        self.kinematics = kinematics
        self.release_threshold_pa = release_threshold_pa
        self.doubt = doubt if doubt is not None else DoubtRule()
        self.pad = pad
        self.settling = settling
        self.loose_settling = loose_settling
        self.centre_of_pressure = centre_of_pressure

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
            The orientation never settled (not even by ``loose_settling``), the pressure saturated,
            or (``DoubtRule.side_force_n``, :class:`PadSideContact`) the press met the pad's side.
        PressReleased
            (``release_threshold_pa``) The pad had let go before its orientation settled (tested
            after the side test: a light press on the pad's side that let go stays one).
        """
        kin = self.kinematics
        pivot_pose = kin.forward_kinematics(q, link=kin.spec.pivot_link)
        pivot = pivot_pose.position_m
        loose = False
        try:
            contact = self._oriented(readings, pivot, baseline_pa, self.settling)
        except OrientationNotSettledError as err:
            if self.loose_settling is None:
                raise NoContactMeasured(str(err)) from err
            try:
                contact, loose = self._oriented(readings, pivot, baseline_pa, self.loose_settling), True
            except ValueError as loose_err:
                raise NoContactMeasured(str(loose_err)) from loose_err
        except ValueError as err:  # saturated, too few readings
            raise NoContactMeasured(str(err)) from err
        load = pad_load(pivot_pose.rotation, contact.normal, contact.force_n, self.pad.spring_stiffness_nm_per_rad,
                        self.pad.half_width_m)
        touched = contact.position_m + (load.offset_m if self.centre_of_pressure else 0.0)
        surface = self.pad.surface_point(touched, contact.normal, contact.force_n)
        p_obj, n_obj = frame.to_object(surface[None], contact.normal[None])
        normal = n_obj[0] / np.linalg.norm(n_obj[0])
        cosine = None if approach_dir is None else float(np.dot(normal, -np.asarray(approach_dir, float)))
        peak_rise_pa = max(r.pressure_pa for r in readings) - baseline_pa
        quality = ContactQuality(contact.force_n, len(readings), cosine, load.tilt_rad,
                                 tuple(float(v) for v in load.pad_uv_m),
                                 load.rim_distance_m(self.pad.half_width_m),
                                 peak_force_n=self.force_estimate_n(peak_rise_pa), loosely_settled=loose)
        quality = replace(quality, doubtful=self.doubt.doubtful(quality))
        if self.doubt.side_contact(quality):
            raise PadSideContact(f"the press reached {quality.peak_force_n:.2f} N with the pad turned "
                                    f"{np.degrees(load.tilt_rad):.1f} deg: the pad's side or corner, not its face")
        # After the side test: a light press that let go is still one on the pad's side, whose place the GPIS uses.
        if self.release_threshold_pa is not None:
            released_n = self.force_estimate_n(self.release_threshold_pa)
            if contact.force_n < released_n:
                raise PressReleased(f"the pad had let go: {contact.force_n:.2f} N when its orientation settled "
                                    f"(peak {quality.peak_force_n:.2f} N), below the contact's end at "
                                    f"{self.release_threshold_pa:.0f} Pa ({released_n:.2f} N)")
        return MeasuredContact(contact, p_obj[0], normal, quality)

    def _oriented(self, readings, pivot: np.ndarray, baseline_pa: float, settling: SettlingConfig) -> OrientedContact:
        return oriented_contact(readings, pivot, self.kinematics.pivot_to_pad_in_body, baseline_pa,
                                pad=self.pad.force_model, settling=settling, alignment=self.pad.alignment)

    def pad_centre(self, q: np.ndarray, frame: ObjectFrame) -> np.ndarray:
        """(3,) pad-face centre from the encoders' forward kinematics, object frame, metres: where a
        press without a measured contact (on the pad's side) was made."""
        return frame.to_object(self.kinematics.forward_kinematics(q).position_m[None])[0]

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
