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

from explorer.loop import LOOP_SETTLING, PAD, LoopConfig, Recorder, TouchRecord
from explorer.positioner import Positioner
from explorer.strategies import ExplorationState, VarianceStrategy
from explorer.teleop.devices import InputDevice, TeleopCommand
from explorer.touch import ObjectPrior
from reconstruction.gpis import GPIS
from sensor.contact_detection import PressureContactDetector
from sensor.normal_estimation import OrientationNotSettledError, SettlingConfig, oriented_contact
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
        Motion into the surface stops at this pad force.
    pad_compliance_m_per_n : float
        Pad compression per newton, added back to the contact point (as the loop does).
    """

    control_period_s: float = 1.0 / 30.0
    max_speed_mps: float = 0.03
    max_rate_radps: float = 0.5
    reference_gain_per_s: float = 5.0
    damping: float = 1e-3
    joint_speed_rad_s: float = 0.5
    press_force_n: float = 1.5
    pad_compliance_m_per_n: float = LoopConfig.pad_compliance_m_per_n

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


class TeleopSession:
    """Runs a device against an arm and sensor, recording contacts and updating the GPIS.

    Parameters
    ----------
    robot : robots.interface.Robot
    sensor : sensor.interface.TactileSensor (opened by the caller)
    kinematics : robots.kinematics.ArmKinematics
    positioner : Positioner
        The stand (its current pose carries contacts into the object frame).
    prior : ObjectPrior
        Object frame; bounds the GPIS and the suggestion grid.
    recorder : Recorder
    config : TeleopConfig
    on_update : callable (TeleopSession) -> None, optional
        Called after each recorded contact (the sim glue draws with it).
    """

    def __init__(self, robot, sensor, kinematics, positioner: Positioner, prior: ObjectPrior,
                 recorder: Recorder | None = None, config: TeleopConfig = TeleopConfig(),
                 on_update: Callable[["TeleopSession"], None] | None = None,
                 detector: PressureContactDetector | None = None, settling: SettlingConfig | None = None):
        self.robot = robot
        self.sensor = sensor
        self.kin = kinematics
        self.positioner = positioner
        self.prior = prior
        self.recorder = recorder or Recorder()
        self.config = config
        self.on_update = on_update
        self.detector = detector or PressureContactDetector()
        self.settling = settling or SettlingConfig(**LOOP_SETTLING)
        self.gpis = GPIS(bounds=prior.bounds())
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
                self._force_n = PAD.force_estimate_n(reading.pressure_pa - self._press.baseline_pa)
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
        pivot = self.kin.forward_kinematics(q, link=self.kin.spec.pivot_link).position_m
        try:
            contact = oriented_contact(resting, pivot, self.kin.pivot_to_pad_in_body, press.baseline_pa,
                                       settling=self.settling)
        except (OrientationNotSettledError, ValueError):
            return  # not settled yet (or saturated): try again next period
        press.recorded = True
        if self._joint_state_t_s != t_s:  # replay takes the pose from the joint state at t_s
            self.recorder.joint_state(t_s, q)
            self._joint_state_t_s = t_s
        self._record(contact, self.kin.forward_kinematics(q).z_axis, (self._rest_since_s, t_s))

    def _record(self, contact, pad_axis_world: np.ndarray, press_t_s: tuple[float, float]) -> None:
        surface = contact.position_m + contact.normal * contact.force_n * self.config.pad_compliance_m_per_n
        p_obj, n_obj = self.positioner.to_object(surface[None], contact.normal[None])
        _, axis_obj = self.positioner.to_object(np.zeros((1, 3)), pad_axis_world[None])
        pose = self.positioner.pose()
        normal = n_obj[0] / np.linalg.norm(n_obj[0])
        index = len(self.contacts)
        record = TouchRecord(index, "contact", p_obj[0], axis_obj[0], pose.yaw_rad, pose.tilt_rad,
                             contact=contact, position_m=p_obj[0], normal=normal, t_s=contact.t_s,
                             press_t_s=press_t_s)
        self.recorder.touch(record)
        teleop_contact = TeleopContact(index, p_obj[0], normal, contact)
        self.contacts.append(teleop_contact)
        try:
            self.gpis.add(p_obj[0], normal)
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


