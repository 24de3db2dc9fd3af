"""SimArm: a RobotSpec arm in a SimWorld, position-controlled, with the passive spring fingertip.

Control: actuated joints use PyBullet POSITION_CONTROL with the URDF effort limits. Motions are
commanded every control tick (``control_steps`` physics steps; 4 x 1/480 s = 120 Hz by default),
and a guarded move calls its ``stop()`` predicate once per tick.

Fingertip: the spring joints' default velocity motors hold velocity 0 with at most the spring's
friction torque (VELOCITY_CONTROL with that force: Coulomb friction with stiction, so the module stops
inside a torque band and rests at different angles depending on the approach; 0 switches it off) and a
pre-step hook applies ``tau = -k theta - c theta_dot`` in TORQUE_CONTROL before every physics step.
The pad gets the spec's friction and contact softness.

Encoders: the loop commands and reads encoder angles. With a calibration offset ``o`` the joint
controller servoes ``true + o`` to the command, so the true arm stands ``o`` away from where the
nominal kinematics put it; backlash and noise only enter the reported angles. The URDF limits are
the controller's software limits on the encoder angles; a real arm's mechanical stops lie beyond
them, so with an offset the simulated stops move :data:`MECHANICAL_STOP_MARGIN_RAD` beyond the true
angle at each software limit (otherwise a command at a software limit would end ``o`` short of its
target against the URDF stop and be taken for a blocked move).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from robots.interface import GuardedMoveResult, MoveNotReachedError, Robot, checked_joint_positions
from robots.pybullet_types import ContactPoint, JointInfo, JointState, LinkInertia, LinkState
from robots.sim_world import SimWorld, import_pybullet
from robots.spec import RobotSpec
from robots.urdf_check import check_spec_against_urdf
from common.pad_state import PadState

REACHED_TOLERANCE_RAD = 2e-3
SETTLE_TIMEOUT_S = 1.0
#: How far a joint's mechanical stop lies beyond the true angle at its software limit, radians.
MECHANICAL_STOP_MARGIN_RAD = float(np.radians(1.0))
STABILITY_MARGIN = 2.0
#: A free move (:meth:`SimArm.move_joints`) stops once one arm link presses this hard on another
#: body, newtons: a real arm's collision detection (a protective stop). Assumption: well above
#: the fingertip's presses (at most ~10 N) and far below the kilonewtons a position-controlled
#: simulated arm reaches when it drives its hand into the object and wedges (issue 12).
PROTECTIVE_STOP_N = 50.0


@dataclass(frozen=True)
class EncoderModel:
    """What the joint encoders add to the true joint angles.

    Attributes
    ----------
    noise_std_rad : float
        Standard deviation of white Gaussian noise, radians.
    resolution_rad : float
        Quantisation step, radians (0: none).
    seed : int or None
        Seed of the noise generator.
    offset_rad : tuple of float
        Calibration error per joint, radians: encoder reading minus true angle at rest (empty: none).
    backlash_rad : float
        Gear play between the motor-side encoder and the link, radians: the reading leads the true
        angle by half of it in the direction of the joint's last motion.
    """

    noise_std_rad: float = 0.0
    resolution_rad: float = 0.0
    seed: int | None = 0
    offset_rad: tuple[float, ...] = ()
    backlash_rad: float = 0.0

    def __post_init__(self) -> None:
        if self.noise_std_rad < 0.0 or self.resolution_rad < 0.0 or not self.backlash_rad >= 0.0:
            raise ValueError(f"encoder noise, resolution and backlash must be >= 0, got {self}")
        object.__setattr__(self, "offset_rad", tuple(float(v) for v in self.offset_rad))
        if not all(np.isfinite(self.offset_rad)):
            raise ValueError(f"encoder offset_rad must be finite, got {self.offset_rad}")


@dataclass(frozen=True)
class ArmContact:
    """A contact between an arm link and something in the world (plain data).

    Attributes
    ----------
    link : str
        Arm link name.
    other : str
        Name of the touched body (object name, 'table', 'ground').
    object_key : int or None
        The touched object's :class:`ObjectHandle` key; None for table, ground or robots.
    point_m : (3,) float
        Contact point on the other body, world frame, metres.
    normal : (3,) float
        Outward surface normal of the other body at the point, world frame.
    normal_force_n : float
    """

    link: str
    other: str
    object_key: int | None
    point_m: np.ndarray
    normal: np.ndarray
    normal_force_n: float



class SimArm(Robot):
    """The simulated arm; implements :class:`robots.interface.Robot`.

    Parameters
    ----------
    world : SimWorld
    spec : RobotSpec
    q_init_rad : (dof,) float or None
        Initial joint positions (default: the spec's home).
    spring_stiffness_nm_per_rad, spring_damping_nms_per_rad : float or None
        Spring law (default: the spec's).
    encoder : EncoderModel
    spring_friction_nm : float
        Coulomb (and stiction) friction torque of each spring joint, N m (0: frictionless).
    link_length_error_m : mapping joint name -> metres, optional
        The true arm's links are this much longer than ``spec``'s URDF says
        (:mod:`robots.link_lengths`); the nominal model (``spec``) is what the caller computes with.
    control_steps : int
        Physics steps per control tick.
    position_gain, velocity_gain : float
        PyBullet position-motor gains.
    """

    def __init__(
        self,
        world: SimWorld,
        spec: RobotSpec,
        q_init_rad=None,
        spring_stiffness_nm_per_rad: float | None = None,
        spring_damping_nms_per_rad: float | None = None,
        encoder: EncoderModel = EncoderModel(),
        spring_friction_nm: float = 0.0,
        link_length_error_m=None,
        control_steps: int = 4,
        position_gain: float = 0.3,
        velocity_gain: float = 1.0,
    ):
        check_spec_against_urdf(spec)
        if control_steps < 1:
            raise ValueError(f"control_steps must be >= 1, got {control_steps}")
        self.world = world
        self.spec = spec
        self.link_length_error_m = dict(link_length_error_m or {})
        self._pb = import_pybullet()
        self._client = world.client
        self.body = self._load_true_arm(world, spec)
        pb, client = self._pb, self._client
        infos = [JointInfo.from_pybullet(pb.getJointInfo(self.body, i, physicsClientId=client))
                 for i in range(pb.getNumJoints(self.body, physicsClientId=client))]
        self._joint_info = infos
        self._joint_index = {info.name: info.index for info in infos}
        self._link_index = {info.child_link_name: info.index for info in infos}
        self._link_name = {index: name for name, index in self._link_index.items()}
        self._arm_joints = [self._joint_index[n] for n in spec.joint_names]
        self._spring_joints = [self._joint_index[n] for n in spec.spring_joint_names]
        self.lower_rad = np.array([infos[i].lower_rad for i in self._arm_joints])
        self.upper_rad = np.array([infos[i].upper_rad for i in self._arm_joints])
        self.effort_nm = np.array([infos[i].effort_nm for i in self._arm_joints])
        self.velocity_limit_rad_s = np.array([infos[i].velocity_rad_s for i in self._arm_joints])
        self._pad = self._link_index[spec.pad_link]
        self._sensor_body = self._link_index[spec.sensor_body_link]
        self.control_steps = int(control_steps)
        self._gains = (float(position_gain), float(velocity_gain))
        self.encoder = encoder
        self._rng = np.random.default_rng(encoder.seed)
        if encoder.offset_rad and len(encoder.offset_rad) != spec.dof:
            raise ValueError(f"encoder offset_rad has {len(encoder.offset_rad)} values, robot {spec.name!r} has "
                             f"{spec.dof} joints")
        self._offset_rad = np.array(encoder.offset_rad) if encoder.offset_rad else np.zeros(spec.dof)
        if np.any(self._offset_rad != 0.0):
            for index, lower, upper, offset in zip(self._arm_joints, self.lower_rad, self.upper_rad, self._offset_rad):
                pb.changeDynamics(self.body, index, jointLowerLimit=float(lower - offset - MECHANICAL_STOP_MARGIN_RAD),
                                  jointUpperLimit=float(upper - offset + MECHANICAL_STOP_MARGIN_RAD),
                                  physicsClientId=client)
        self._backlash_side = np.zeros(spec.dof)  # -1, 0, +1: direction of each joint's last motion
        self._backlash_anchor = None
        if not (np.isfinite(spring_friction_nm) and spring_friction_nm >= 0.0):
            raise ValueError(f"spring_friction_nm must be finite and >= 0 N m, got {spring_friction_nm}")
        self.spring_friction_nm = float(spring_friction_nm)
        try:
            stiffness, damping = spring_stiffness_nm_per_rad, spring_damping_nms_per_rad
            self.set_spring(spec.spring_stiffness_nm_per_rad if stiffness is None else stiffness,
                            spec.spring_damping_nms_per_rad if damping is None else damping)
            self.reset_joint_positions(spec.home_q if q_init_rad is None else q_init_rad)
        except ValueError:
            pb.removeBody(self.body, physicsClientId=client)
            raise
        friction = [self.spring_friction_nm] * 2
        pb.setJointMotorControlArray(self.body, self._spring_joints, pb.VELOCITY_CONTROL,
                                     targetVelocities=[0.0, 0.0], forces=friction, physicsClientId=client)
        pb.changeDynamics(
            self.body, self._pad,
            lateralFriction=spec.pad_lateral_friction,
            contactStiffness=spec.pad_contact_stiffness_n_per_m,
            contactDamping=spec.pad_contact_damping_ns_per_m,
            physicsClientId=client,
        )
        self._remove_hook = world.add_pre_step_hook(self._apply_spring_torque)

    def remove(self) -> None:
        """Take the arm out of its world (body and spring hook)."""
        self._remove_hook()
        self._pb.removeBody(self.body, physicsClientId=self._client)

    def reset_joint_positions(self, q_rad) -> None:
        """Teleport the arm to ``q_rad`` ((dof,) radians) at rest, springs at 0, and hold it there.

        No dynamics run: use it to set up a scene, not as a motion.
        """
        q = self._checked_q(q_rad, "q_rad")
        pb, client = self._pb, self._client
        for index, value in zip(self._arm_joints, q - self._offset_rad):
            pb.resetJointState(self.body, index, float(value), 0.0, physicsClientId=client)
        self._backlash_side[:] = 0.0
        self._backlash_anchor = None
        for index in self._spring_joints:
            pb.resetJointState(self.body, index, 0.0, 0.0, physicsClientId=client)
        self._command(q, np.zeros(self.dof))

    # ---- spring ------------------------------------------------------------------------------

    def set_spring(self, stiffness_nm_per_rad: float, damping_nms_per_rad: float) -> None:
        """Change the spring law ``tau = -k theta - c theta_dot`` (N m/rad, N m s/rad).

        Raises
        ------
        ValueError
            For negative values, or values the explicit per-step update cannot integrate stably
            at this world's time step (``k dt^2 / I + 2 c dt / I`` must stay below 2, half the
            stability bound, with ``I`` the module's inertia about the spring axis).
        """
        k, c = float(stiffness_nm_per_rad), float(damping_nms_per_rad)
        if not k >= 0.0 or not c >= 0.0:
            raise ValueError(f"spring stiffness and damping must be >= 0, got {k}, {c}")
        dt = self.world.time_step_s
        inertia = self.spring_inertia_kgm2()
        load = k * dt * dt / inertia + 2.0 * c * dt / inertia
        if load >= STABILITY_MARGIN:
            raise ValueError(
                f"spring k = {k} N m/rad, c = {c} N m s/rad is too stiff for time step {dt:.3g} s with the "
                f"module's inertia {inertia:.3g} kg m^2 about the pivot (k dt^2/I + 2 c dt/I = {load:.2f}, "
                f"must be < {STABILITY_MARGIN}); use a smaller time_step_s or a softer spring"
            )
        self.spring_stiffness_nm_per_rad = k
        self.spring_damping_nms_per_rad = c

    def spring_inertia_kgm2(self) -> float:
        """Smallest inertia of the links the springs carry about either spring axis, kg m^2."""
        pb, client = self._pb, self._client
        inertias = []
        for joint in self._spring_joints:
            frame = self.link_state(self._link_name[joint])
            axis = frame.rotation @ self._joint_info[joint].axis
            links = self._descendants(joint)
            inertias.append(sum(
                LinkInertia.from_pybullet(
                    pb.getDynamicsInfo(self.body, link, physicsClientId=client),
                    pb.getLinkState(self.body, link, computeForwardKinematics=1, physicsClientId=client),
                ).about_axis(frame.position_m, axis)
                for link in links
            ))
        return float(min(inertias))

    def _descendants(self, link: int) -> list[int]:
        """``link`` and every link below it (PyBullet numbers parents before children)."""
        found = [link]
        for info in self._joint_info:
            if info.parent_index in found and info.index not in found:
                found.append(info.index)
        return found

    def _apply_spring_torque(self, _t_s: float) -> None:
        pb = self._pb
        k, c = self.spring_stiffness_nm_per_rad, self.spring_damping_nms_per_rad
        # raw getJointStates tuples (position, velocity, ...): this runs before every physics step
        raw = pb.getJointStates(self.body, self._spring_joints, physicsClientId=self._client)
        torques = [-k * s[0] - c * s[1] for s in raw]
        pb.setJointMotorControlArray(self.body, self._spring_joints, pb.TORQUE_CONTROL, forces=torques,
                                     physicsClientId=self._client)

    def spring_angles(self) -> np.ndarray:
        """True spring joint angles (2,), radians (not measurable on the real arm)."""
        return np.array([s.position_rad for s in self._joint_states(self._spring_joints)])

    def apply_pad_wrench(self, force_n=(0.0, 0.0, 0.0), torque_nm=(0.0, 0.0, 0.0)) -> None:
        """Push the sensor body with an external force (at its origin) and torque, world frame.

        Acts during the next physics step only (call it from a pre-step hook to keep pushing).
        """
        pb = self._pb
        state = self.link_state(self.spec.sensor_body_link)
        pb.applyExternalForce(self.body, self._sensor_body, list(map(float, force_n)), state.position_m.tolist(),
                              pb.WORLD_FRAME, physicsClientId=self._client)
        pb.applyExternalTorque(self.body, self._sensor_body, list(map(float, torque_nm)), pb.WORLD_FRAME,
                               physicsClientId=self._client)

    # ---- Robot interface ---------------------------------------------------------------------

    def _load_true_arm(self, world: SimWorld, spec: RobotSpec) -> int:
        """Load the arm's URDF, with the link-length errors written into a temporary copy."""
        if not any(self.link_length_error_m.values()):
            return world.load_urdf(spec.urdf_path, spec.base_position_m, spec.base_quat_wxyz, fixed_base=True)
        import tempfile

        from robots.link_lengths import with_link_length_errors

        with tempfile.TemporaryDirectory(prefix="true_arm_") as directory:
            true_spec = with_link_length_errors(spec, self.link_length_error_m, Path(directory))
            return world.load_urdf(true_spec.urdf_path, spec.base_position_m, spec.base_quat_wxyz, fixed_base=True)

    @property
    def dof(self) -> int:
        return self.spec.dof

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self.spec.joint_names

    def time_s(self) -> float:
        return self.world.time_s

    def true_joint_positions(self) -> np.ndarray:
        """Actuated joint positions (dof,), radians, without encoder effects."""
        raw = self._pb.getJointStates(self.body, self._arm_joints, physicsClientId=self._client)
        return np.array([float(s[0]) for s in raw])  # raw tuples: read every control tick

    def servo_positions(self) -> np.ndarray:
        """What the joint controllers servo (dof,), radians: true angles plus the calibration offset."""
        return self.true_joint_positions() + self._offset_rad

    def joint_positions(self) -> np.ndarray:
        """Encoder readings (dof,), radians: true angles plus offset, backlash and noise, quantised."""
        q = self.servo_positions()
        if self.encoder.backlash_rad > 0.0:
            q = q + 0.5 * self.encoder.backlash_rad * self._backlash_direction(q)
        if self.encoder.noise_std_rad > 0.0:
            q = q + self._rng.normal(0.0, self.encoder.noise_std_rad, q.shape)
        if self.encoder.resolution_rad > 0.0:
            q = np.round(q / self.encoder.resolution_rad) * self.encoder.resolution_rad
        return q

    def _backlash_direction(self, q: np.ndarray) -> np.ndarray:
        """Sign of each joint's last motion larger than the play (play operator on the angles)."""
        if self._backlash_anchor is None:
            self._backlash_anchor = q.copy()
        moved = np.abs(q - self._backlash_anchor) > 0.5 * self.encoder.backlash_rad
        self._backlash_side[moved] = np.sign(q - self._backlash_anchor)[moved]
        self._backlash_anchor[moved] = q[moved]
        return self._backlash_side

    def move_joints(self, q, speed_rad_s: float = 1.0) -> None:
        """Move to ``q`` along a straight joint-space line and wait until it is reached.

        Raises
        ------
        MoveNotReachedError
            When the arm has not reached ``q`` within ``SETTLE_TIMEOUT_S`` after the motion, or
            when a link pressed more than ``PROTECTIVE_STOP_N`` on another body on the way (it
            then holds where it stopped).
        """
        target = self._checked_q(q, "q")
        collision = []
        result = self._follow(target[None], stop=lambda: self._collided(collision), speed_rad_s=speed_rad_s)
        error = np.max(np.abs(self.servo_positions() - target))
        if result.stopped:
            link, other, force = collision[0]
            raise MoveNotReachedError(f"protective stop: {link} pressed {force:.0f} N on {other}, "
                                      f"{np.degrees(error):.2f} deg from the target", body=other, link=link)
        if error > REACHED_TOLERANCE_RAD:
            raise MoveNotReachedError(
                f"arm stopped {np.degrees(error):.2f} deg away from its target (blocked by a contact?)"
            )

    def guarded_move(self, path, stop: Callable[[], bool], speed_rad_s: float = 0.2) -> GuardedMoveResult:
        """Follow ``path`` ((k, dof) radians) from the current position, checking ``stop()`` each tick.

        The path is interpolated linearly so that the fastest joint moves at ``speed_rad_s`` (or
        slower where a joint's URDF velocity limit is lower). When ``stop()`` returns True the arm
        holds the position it has reached and the call returns.
        """
        path = np.asarray(path, dtype=float)
        if path.ndim != 2 or path.shape[1] != self.dof or len(path) == 0:
            raise ValueError(f"path must have shape (k, {self.dof}) with k >= 1, got {path.shape}")
        for i, waypoint in enumerate(path):
            self._checked_q(waypoint, f"path[{i}]")
        if not callable(stop):
            raise TypeError("stop must be a callable returning bool")
        return self._follow(path, stop, speed_rad_s)

    # ---- state -------------------------------------------------------------------------------

    def hold(self, duration_s: float, stop: Callable[[], bool] | None = None) -> GuardedMoveResult:
        if not duration_s >= 0.0:
            raise ValueError(f"duration_s must be >= 0, got {duration_s}")
        q = self.servo_positions()
        self._command(q, np.zeros(self.dof))
        tick_s = self.control_steps * self.world.time_step_s
        for _ in range(int(np.ceil(duration_s / tick_s))):
            if stop is not None and stop():
                return GuardedMoveResult(stopped=True, q=self.joint_positions(), waypoint_index=0)
            self.world.step(self.control_steps)
        return GuardedMoveResult(stopped=False, q=self.joint_positions(), waypoint_index=0)

    def link_state(self, link: str) -> LinkState:
        """Pose and velocity of an arm link's URDF frame, world frame."""
        if link not in self._link_index:
            raise ValueError(f"robot {self.spec.name!r} has no link {link!r}; links: {sorted(self._link_index)}")
        raw = self._pb.getLinkState(self.body, self._link_index[link], computeLinkVelocity=1,
                                    computeForwardKinematics=1, physicsClientId=self._client)
        return LinkState.from_pybullet(raw)

    def pad_contacts(self) -> list[ContactPoint]:
        """Raw contact points of the pad link (PyBullet types; robots/ internal)."""
        raw = self._pb.getContactPoints(bodyA=self.body, linkIndexA=self._pad, physicsClientId=self._client)
        return [ContactPoint.from_pybullet(c) for c in raw]

    def contacts(self) -> list[ArmContact]:
        """Every contact of any arm link with another body, as plain data."""
        raw = self._pb.getContactPoints(bodyA=self.body, physicsClientId=self._client)
        contacts = []
        for c in map(ContactPoint.from_pybullet, raw):
            if c.body_b == self.body:
                continue
            contacts.append(ArmContact(
                link=self._link_name.get(c.link_a, "base"),
                other=self.world.body_name(c.body_b),
                object_key=self.world.object_key(c.body_b),
                point_m=c.position_on_b_m,
                normal=c.normal_on_b,
                normal_force_n=c.normal_force_n,
            ))
        return contacts

    def _collided(self, found: list) -> bool:
        """Whether one link presses more than ``PROTECTIVE_STOP_N`` on another body; appends
        (link, other body, newtons) to ``found`` when it does."""
        raw = self._pb.getContactPoints(bodyA=self.body, physicsClientId=self._client)
        per_link: dict[tuple[int, int], float] = {}
        for c in raw:
            if c[2] != self.body and c[9] > 0.0:
                key = (c[3], c[2])
                per_link[key] = per_link.get(key, 0.0) + c[9]
        for (link, other), force in per_link.items():
            if force > PROTECTIVE_STOP_N:
                found.append((self._link_name.get(link, "base"), self.world.body_name(other), force))
                return True
        return False

    def pad_normal_force_n(self) -> float:
        """The pad's load as its barometer feels it, newtons (:meth:`_felt_force_n`): ``pad_state().normal_force_n``
        without the pose queries in free motion (what a simulated barometer needs every step)."""
        raw = self._pb.getContactPoints(bodyA=self.body, linkIndexA=self._pad, physicsClientId=self._client)
        loaded = [c for c in raw if c[9] > 0.0]
        if not loaded:
            return 0.0
        return self._felt_force_n(np.array([c[7] for c in loaded]), np.array([c[9] for c in loaded]))

    def _felt_force_n(self, normals: np.ndarray, forces_n: np.ndarray) -> float:
        """What the barometer under the pad feels of contact forces ``forces_n`` ((k,) newtons, > 0)
        along ``normals`` ((k, 3), world frame): each force's component along the pad's face axis,
        plus ``spec.pad_side_pressure_gain`` times its component across it (a push on the pad's side)."""
        quat_xyzw = self._pb.getLinkState(self.body, self._pad, computeForwardKinematics=1,
                                          physicsClientId=self._client)[5]
        axis = np.asarray(self._pb.getMatrixFromQuaternion(quat_xyzw)).reshape(3, 3)[:, 2]
        along = np.clip(np.abs(normals @ axis), 0.0, 1.0)
        across = np.sqrt(1.0 - along**2)
        return float(forces_n @ (along + self.spec.pad_side_pressure_gain * across))

    def pad_state(self) -> PadState:
        """True state of the sensor body and the pad's contact, as of the last physics step."""
        body = self.link_state(self.spec.sensor_body_link)
        contacts = [c for c in self.pad_contacts() if c.normal_force_n > 0.0]
        total = float(sum(c.normal_force_n for c in contacts))
        force = 0.0
        point = normal = None
        if total > 0.0:
            forces = np.array([c.normal_force_n for c in contacts])
            force = self._felt_force_n(np.array([c.normal_on_b for c in contacts]), forces)
            weights = forces / total
            point = weights @ np.array([c.position_on_b_m for c in contacts])
            normal = weights @ np.array([c.normal_on_b for c in contacts])
            normal = normal / np.linalg.norm(normal)
        return PadState(
            t_s=self.world.time_s,
            position_m=body.position_m,
            quat_wxyz=body.quat_wxyz,
            lin_vel_mps=body.lin_vel_mps,
            ang_vel_radps=body.ang_vel_radps,
            normal_force_n=force,
            contact_point_m=point,
            contact_normal=normal,
        )

    # ---- internals ---------------------------------------------------------------------------

    def _joint_states(self, indices: list[int]) -> list[JointState]:
        raw = self._pb.getJointStates(self.body, indices, physicsClientId=self._client)
        return [JointState.from_pybullet(s) for s in raw]

    def _checked_q(self, q, name: str) -> np.ndarray:
        return checked_joint_positions(q, name, self.joint_names, self.lower_rad, self.upper_rad)

    def _command(self, q: np.ndarray, qdot: np.ndarray) -> None:
        kp, kd = self._gains
        self._pb.setJointMotorControlArray(
            self.body, self._arm_joints, self._pb.POSITION_CONTROL,
            targetPositions=(q - self._offset_rad).tolist(), targetVelocities=qdot.tolist(), forces=self.effort_nm.tolist(),
            positionGains=[kp] * self.dof, velocityGains=[kd] * self.dof, physicsClientId=self._client,
        )

    def _follow(self, path: np.ndarray, stop: Callable[[], bool] | None, speed_rad_s: float) -> GuardedMoveResult:
        if not speed_rad_s > 0.0:
            raise ValueError(f"speed_rad_s must be positive, got {speed_rad_s}")
        tick_s = self.control_steps * self.world.time_step_s
        start = self.servo_positions()
        points = np.vstack([start[None], path])
        joint_speed = np.minimum(speed_rad_s, self.velocity_limit_rad_s)  # never beyond the URDF limits
        durations = np.max(np.abs(np.diff(points, axis=0)) / joint_speed, axis=1)
        ends = np.cumsum(durations)
        total = float(ends[-1]) if len(ends) else 0.0
        t = 0.0
        settle_ticks = int(np.ceil(SETTLE_TIMEOUT_S / tick_s))
        ticks_after_end = 0
        while True:
            segment = min(int(np.searchsorted(ends, t, side="right")), len(path) - 1)
            if stop is not None and stop():
                self._command(self.servo_positions(), np.zeros(self.dof))
                return GuardedMoveResult(stopped=True, q=self.joint_positions(), waypoint_index=segment)
            if t >= total:
                target, velocity = path[-1], np.zeros(self.dof)
                reached = np.max(np.abs(self.servo_positions() - target)) <= REACHED_TOLERANCE_RAD
                if reached or ticks_after_end >= settle_ticks:
                    return GuardedMoveResult(stopped=False, q=self.joint_positions(), waypoint_index=len(path) - 1)
                ticks_after_end += 1
            else:
                seg_start = ends[segment] - durations[segment]
                fraction = (t - seg_start) / durations[segment] if durations[segment] > 0 else 1.0
                target = points[segment] + fraction * (points[segment + 1] - points[segment])
                velocity = (points[segment + 1] - points[segment]) / max(durations[segment], 1e-12)
            self._command(target, velocity)
            self.world.step(self.control_steps)
            t += tick_s
