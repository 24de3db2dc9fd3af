"""A teleoperated exploration: the operator jogs the pad, the framework records and reconstructs.

The arm is jogged in a compliant mode: the device's Cartesian pad velocity is turned into joint
motion by resolved-rate IK (damped least squares on the kinematics Jacobian, with a low-gain pull
towards the integrated pad reference), and motion into the surface stops once the pad presses
with ``press_force_n``. Contacts come from the same :class:`PressureContactDetector` and
:func:`oriented_contact` as the autonomous loop: when the pad rests in contact (no motion asked,
or pressing at the force limit) and its orientation has settled, the contact is recorded, added
to the GPIS, and the most uncertain surface point (``VarianceStrategy.surface_variance``) becomes
the suggested next touch. Everything goes through the loop's :class:`Recorder` (session format).

One detector watches the whole stream and is never reset (the operator, not the framework,
decides where a press begins). A recorded contact uses the readings of the press in progress
that arrived after the pad came to rest, ``rest_since < t <= record time``; the touch event
stores that span as ``press_t_s`` and a joint state is logged at the record time, so
``tactile-reconstruct`` can detect the contact again from the raw stream (explorer/replay.py).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy.spatial.transform import Rotation

from explorer.contact import LOOP_SETTLING, ContactPipeline, MeasuredContact, NoContactMeasured, ObjectFrame
from explorer.loop import Recorder
from explorer.rig import Rig
from explorer.strategies import ExplorationState, VarianceStrategy
from explorer.teleop.devices import InputDevice, TeleopCommand
from explorer.touch import TouchOutcome
from reconstruction.gpis import GPIS
from sensor.contact_detection import PressureContactDetector
from sensor.normal_estimation import SettlingConfig
from sensor.reading import Reading


@dataclass(frozen=True)
class TeleopConfig:
    """Jogging and recording settings (SI units).

    Attributes
    ----------
    control_period_s : float
        How often the device is polled and the joint reference updated.
    max_speed_mps, max_rate_radps : float
        Commands are clipped to these pad speeds.
    reference_gain_per_s : float
        Low gain pulling the joint reference back onto the integrated pad pose (stops drift).
    damping : float
        Damped-least-squares damping of the resolved-rate IK.
    joint_speed_rad_s : float
        Fastest joint speed of a jog step.
    press_force_n : float
        Motion into the surface stops at this pad force (estimated with the rig's pad calibration).
    """

    control_period_s: float = 1.0 / 30.0
    max_speed_mps: float = 0.03
    max_rate_radps: float = 0.5
    reference_gain_per_s: float = 5.0
    damping: float = 1e-3
    joint_speed_rad_s: float = 0.5
    press_force_n: float = 1.5

    def __post_init__(self):
        for name in ("control_period_s", "max_speed_mps", "max_rate_radps", "joint_speed_rad_s",
                     "press_force_n"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")


@dataclass
class TeleopContact:
    """A recorded contact (object frame) and the suggestion made after it.

    Attributes
    ----------
    index : int
    position_m, normal : (3,) float
        Surface point and outward unit normal, object frame.
    world : OrientedContact
        As measured, world frame.
    suggestion_m : (3,) float or None
        The most uncertain surface point after this contact, object frame.
    """

    index: int
    position_m: np.ndarray
    normal: np.ndarray
    world: object
    suggestion_m: np.ndarray | None = None


@dataclass
class _Press:
    """The contact in progress."""

    baseline_pa: float
    readings: list[Reading] = field(default_factory=list)
    recorded: bool = False


class TeleopController:
    """Runs a device against an arm and sensor, recording contacts and updating the GPIS.

    Parameters
    ----------
    rig : explorer.rig.Rig
        Robot (compliant), sensor (opened by the caller), kinematics, positioner (its current pose
        carries contacts into the object frame), prior (bounds the GPIS and the suggestion grid)
        and the pad calibration.
    recorder : Recorder
    config : TeleopConfig
    on_update : callable (TeleopController) -> None, optional
        Called after each recorded contact (the sim glue draws with it).
    """

    def __init__(self, rig: Rig, recorder: Recorder | None = None, config: TeleopConfig = TeleopConfig(),
                 on_update: Callable[["TeleopController"], None] | None = None,
                 detector: PressureContactDetector | None = None, settling: SettlingConfig = LOOP_SETTLING):
        robot = rig.robot
        self.robot = robot
        self.sensor = rig.sensor
        self.kin = rig.kinematics
        self.positioner = rig.positioner
        self.prior = rig.prior
        self.recorder = recorder or Recorder()
        self.config = config
        self.on_update = on_update
        self.detector = detector or PressureContactDetector()
        self.settling = settling
        self.contact_pipeline = ContactPipeline(rig.kinematics, rig.pad, settling)
        self.gpis = GPIS(bounds=rig.prior.bounds())
        self.strategy = VarianceStrategy()
        self.contacts: list[TeleopContact] = []
        self.suggestion_m: np.ndarray | None = None
        self._press: _Press | None = None
        self._force_n = 0.0
        # The pad has been at rest since this time: readings after it may form the contact.
        self._rest_since_s = float(robot.time_s())
        self._joint_state_t_s: float | None = None  # time of the last logged joint state
        self._q_ref: np.ndarray | None = None
        self._pose_ref: tuple[np.ndarray, Rotation] | None = None

    # ------------------------------------------------------------------ public
    def run(self, device: InputDevice, max_duration_s: float | None = None) -> list[TeleopContact]:
        """Poll ``device`` (opened by the caller) until it asks to quit (or the time is up)."""
        t_end = None if max_duration_s is None else self.robot.time_s() + max_duration_s
        while t_end is None or self.robot.time_s() < t_end:
            command = device.poll()
            if "quit" in command.buttons:
                break
            if "record" in command.buttons:
                self.snapshot()
            self.step(command)
        return self.contacts

    def step(self, command: TeleopCommand) -> None:
        """One control period: jog (or rest) while watching the sensor; record a settled contact."""
        linear, angular = self._limited(command)
        deadline = self.robot.time_s() + self.config.control_period_s - 1e-9
        if not (np.any(linear) or np.any(angular)):
            self._q_ref = self._pose_ref = None
            self.robot.hold(self.config.control_period_s, stop=lambda: self._watch() or self.robot.time_s() >= deadline)
        else:
            self._rest_since_s = float(self.robot.time_s())
            q_next = self._integrate(linear, angular)
            step = float(np.max(np.abs(q_next - self.robot.joint_positions())))
            speed = min(max(step / self.config.control_period_s, 1e-3), self.config.joint_speed_rad_s)
            self.robot.guarded_move(q_next[None], speed_rad_s=speed,
                                    stop=lambda: self._watch() or self.robot.time_s() >= deadline)
        self._watch()  # the last control tick's readings: a rest ends with nothing left to read
        self._maybe_record()

    def snapshot(self):
        """Write the current reconstruction to the session; returns the mesh (None before contacts)."""
        if not self.gpis.n_contacts:
            return None
        mesh = self.gpis.mesh(resolution=48)
        if hasattr(self.recorder, "reconstruction"):
            self.recorder.reconstruction(mesh, self.gpis.n_contacts, self.robot.time_s())
        return mesh

    def to_world(self, points_object: np.ndarray, directions=None):
        """Object-frame points (n, 3) (and directions) in the world at the stand's current pose."""
        return self.positioner.to_world(points_object, directions)

    # ------------------------------------------------------------------ jogging
    def _limited(self, command: TeleopCommand) -> tuple[np.ndarray, np.ndarray]:
        """Clip the command to the speed limits; no motion into the surface at the force limit."""
        cfg = self.config
        linear = _clip_norm(command.linear_mps, cfg.max_speed_mps)
        angular = _clip_norm(command.angular_radps, cfg.max_rate_radps)
        if self._press is not None and self._force_n >= cfg.press_force_n:
            into = self.kin.forward_kinematics(self.robot.joint_positions()).z_axis
            inward = float(linear @ into)
            if inward > 0:
                linear = linear - inward * into
                if np.linalg.norm(linear) < 1e-6:
                    linear = np.zeros(3)
        return linear, angular

    def _integrate(self, linear: np.ndarray, angular: np.ndarray) -> np.ndarray:
        """Advance the pad reference by one period and the joint reference by resolved rates."""
        cfg, dt = self.config, self.config.control_period_s
        if self._q_ref is None:
            self._q_ref = self.robot.joint_positions().copy()
            pose = self.kin.forward_kinematics(self._q_ref)
            self._pose_ref = (pose.position_m.copy(), Rotation.from_matrix(pose.rotation))
        position, rotation = self._pose_ref
        position = position + linear * dt
        rotation = Rotation.from_rotvec(angular * dt) * rotation
        self._pose_ref = (position, rotation)
        pose = self.kin.forward_kinematics(self._q_ref)
        error = np.concatenate([position - pose.position_m,
                                (rotation * Rotation.from_matrix(pose.rotation).inv()).as_rotvec()])
        twist = np.concatenate([linear, angular]) + cfg.reference_gain_per_s * error
        jac = self.kin.jacobian(self._q_ref)
        rates = jac.T @ np.linalg.solve(jac @ jac.T + cfg.damping ** 2 * np.eye(6), twist)
        self._q_ref = np.clip(self._q_ref + rates * dt, self.kin.lower_rad, self.kin.upper_rad)
        return self._q_ref

    # ------------------------------------------------------------------ sensing and recording
    def _watch(self) -> bool:
        """Poll the sensor, record the stream, run the detector; never stops a motion by itself."""
        readings = self.sensor.drain()
        if not readings:
            return False
        t_s = self.robot.time_s()
        self.recorder.readings(readings)
        self.recorder.joint_state(t_s, self.robot.joint_positions())
        self._joint_state_t_s = t_s
        for reading in readings:
            event = self.detector.update(reading)
            if event is not None and event.kind == "start":
                self._press = _Press(event.baseline_pa)
                self.recorder.event("contact_start", event.t_s, baseline_pa=event.baseline_pa)
            elif event is not None and event.kind == "end":
                self._press = None
                self._force_n = 0.0
                self.recorder.event("contact_end", event.t_s)
            if self._press is not None:
                self._press.readings.append(reading)
                self._force_n = self.contact_pipeline.force_estimate_n(reading.pressure_pa - self._press.baseline_pa)
        return False

    def _maybe_record(self) -> None:
        """Record the press once the pad rests in contact with a settled orientation."""
        press = self._press
        if press is None or press.recorded or self._q_ref is not None:
            return
        resting = [r for r in press.readings if r.t_s > self._rest_since_s]
        if len(resting) < 2 or resting[-1].t_s - resting[0].t_s < self.settling.settle_window_s:
            return
        t_s = float(self.robot.time_s())
        q = self.robot.joint_positions()
        frame = ObjectFrame.of_positioner(self.positioner)
        _, axis_obj = frame.to_object(np.zeros((1, 3)), self.kin.forward_kinematics(q).z_axis[None])
        try:
            measured = self.contact_pipeline.measure(resting, press.baseline_pa, q, frame, axis_obj[0])
        except NoContactMeasured:
            return  # not settled yet (or saturated): try again next period
        press.recorded = True
        if self._joint_state_t_s != t_s:  # replay takes the pose from the joint state at t_s
            self.recorder.joint_state(t_s, q)
            self._joint_state_t_s = t_s
        self._record(measured, axis_obj[0], frame, press.baseline_pa, (self._rest_since_s, t_s))

    def _record(self, measured: MeasuredContact, pad_axis_object: np.ndarray, frame: ObjectFrame,
                baseline_pa: float, press_t_s: tuple[float, float]) -> None:
        contact, position, normal = measured.world, measured.position_m, measured.normal
        index = len(self.contacts)
        record = TouchOutcome(index, "contact", position, pad_axis_object, frame.pose.yaw_rad, frame.pose.tilt_rad,
                              contact=contact, position_m=position, normal=normal, t_s=contact.t_s,
                              press_t_s=press_t_s, baseline_pa=baseline_pa, quality=measured.quality)
        self.recorder.touch(record)
        teleop_contact = TeleopContact(index, position, normal, contact)
        self.contacts.append(teleop_contact)
        try:
            self.gpis.add(position, normal)
        except ValueError as err:  # outside the prior box: kept in the record, not in the model
            self.recorder.event("not_modelled", contact.t_s, message=str(err))
            return
        self.suggestion_m = self._most_uncertain()
        teleop_contact.suggestion_m = self.suggestion_m
        if self.suggestion_m is not None:
            self.recorder.event("suggested_touch", contact.t_s, point_m=self.suggestion_m.tolist())
        if self.on_update is not None:
            self.on_update(self)

    def _most_uncertain(self) -> np.ndarray | None:
        points, variance = self.strategy.surface_variance(ExplorationState(self.prior, self.gpis))
        return points[int(np.argmax(variance))].copy() if len(points) else None


def _clip_norm(vector: np.ndarray, limit: float) -> np.ndarray:
    norm = float(np.linalg.norm(vector))
    return vector * (limit / norm) if norm > limit else np.array(vector, float)


