"""A virtual object between the emulated arm controller and the emulated fingertip chips.

With it the exploration loop runs on the hardware backend (SerialArm over the line protocol,
HardwareTactileSensor over the real BMP280/BNO055 drivers on a fake I2C bus) and touches
something: after every tick of the shared :class:`sensor.emulators.FakeClock` the world takes the
controller's TRUE joint angles, places the pad by forward kinematics and sets what the chips
measure.

Contact model (an ideal spring and a linear pad):

* the spring turns the sensor body about its pivot so that the body's +z axis points along minus
  the outward surface normal (the smallest such rotation, so the roll of the commanded body frame
  is kept); free, the body has the commanded orientation;
* the pad face centre ``penetration`` inside the object presses with
  ``force = stiffness x penetration``; the barometer reads ambient plus
  :meth:`sensor.sim.pad_response.PadResponse.pressure_rise_pa` of that force (no lag);
* the IMU reports the body orientation (mounting offset identity, fusion frame = world).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from robots.emulators.arm_controller import EmulatedArmController
from robots.emulators.arm_serial import FakeArmSerial
from robots.kinematics import ArmKinematics
from sensor.emulators.bmp280_chip import BMP280Chip
from sensor.emulators.bno055_chip import BNO055Chip
from common.clock import FakeClock
from sensor.emulators.fake_smbus import FakeSMBus
from sensor.sim.pad_response import PadResponse
from common.rotations import rotation_from_wxyz, wxyz_from_rotation

GRAVITY_MPS2 = 9.80665
BMP280_ADDRESS = 0x76
BNO055_ADDRESS = 0x28


@dataclass(frozen=True)
class VirtualSphere:
    """A rigid sphere.

    Attributes
    ----------
    centre_m : (3,) float, world frame, metres
    radius_m : float, metres
    """

    centre_m: np.ndarray
    radius_m: float

    def __post_init__(self):
        centre = np.asarray(self.centre_m, dtype=float)
        if centre.shape != (3,) or not np.all(np.isfinite(centre)):
            raise ValueError(f"centre_m must be 3 finite numbers, got {self.centre_m!r}")
        if not self.radius_m > 0.0:
            raise ValueError(f"radius_m must be > 0, got {self.radius_m}")
        object.__setattr__(self, "centre_m", centre)
        object.__setattr__(self, "radius_m", float(self.radius_m))

    def outward_normal(self, point_m: np.ndarray) -> np.ndarray:
        """(3,) outward unit normal of the surface point nearest ``point_m`` ((3,) world, metres)."""
        offset = np.asarray(point_m, dtype=float) - self.centre_m
        length = float(np.linalg.norm(offset))
        if length == 0.0:
            raise ValueError("the point is at the sphere's centre: no nearest surface point")
        return offset / length

    def penetration_m(self, point_m: np.ndarray) -> float:
        """Depth of ``point_m`` inside the sphere (negative outside), metres."""
        return self.radius_m - float(np.linalg.norm(np.asarray(point_m, dtype=float) - self.centre_m))


@dataclass(frozen=True)
class TouchState:
    """What the world computed at one instant.

    Attributes
    ----------
    t_s : float
        Clock time, seconds.
    pad_position_m : (3,) float
        Pad face centre, world frame, metres (after alignment when in contact).
    body_rotation : (3, 3) float
        Sensor body -> world.
    penetration_m : float
        Depth of the pad face centre inside the object (0 when free), metres.
    force_n : float
        Contact force, newtons.
    pressure_pa : float
        True pressure given to the barometer, pascals.
    normal : (3,) float or None
        Outward surface normal at the contact, world frame; None when free.
    """

    t_s: float
    pad_position_m: np.ndarray
    body_rotation: np.ndarray
    penetration_m: float
    force_n: float
    pressure_pa: float
    normal: np.ndarray | None


def aligned_rotation(commanded: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """The smallest turn of ``commanded`` ((3, 3) body -> world) that puts body +z along ``-normal``.

    The turn's axis is perpendicular to the body z axis, so the roll about the face axis is kept.
    """
    z_now = commanded[:, 2]
    z_goal = -np.asarray(normal, dtype=float)
    axis = np.cross(z_now, z_goal)
    sine, cosine = float(np.linalg.norm(axis)), float(np.dot(z_now, z_goal))
    if sine < 1e-12:
        if cosine > 0.0:
            return commanded.copy()
        raise ValueError("the pad faces straight away from the surface: the spring cannot align it")
    turn = Rotation.from_rotvec(axis / sine * np.arctan2(sine, cosine))
    return turn.as_matrix() @ commanded


class ContactWorld:
    """Couples an :class:`EmulatedArmController` to a BMP280 and a BNO055 emulator through a sphere.

    Parameters
    ----------
    controller : EmulatedArmController
        Its TRUE joint angles place the pad.
    kinematics : ArmKinematics
        Of the same robot.
    barometer_chip : BMP280Chip
    imu_chip : BNO055Chip
    clock : FakeClock
        Shared by controller, drivers, arm and sensor; :meth:`sleep` advances it.
    sphere : VirtualSphere
        World frame.
    stiffness_n_per_m : float
        Contact force per metre of penetration.
    ambient_pa : float
        Pressure of the free pad, pascals.
    pad : PadResponse
        Force -> pressure rise.
    body_in_imu_wxyz : (4,) float
        The sensor body's orientation in the IMU chip's frame (a mounting offset; identity: ideally
        mounted). The chip reports ``R_world_body R(body_in_imu)^-1``, as
        :class:`sensor.normal_estimation.ImuAlignment` assumes.

    Attributes
    ----------
    state : TouchState
        The latest update.
    max_force_n : float
        Largest force seen.
    """

    def __init__(self, controller: EmulatedArmController, kinematics: ArmKinematics, barometer_chip: BMP280Chip,
                 imu_chip: BNO055Chip, clock: FakeClock, sphere: VirtualSphere, *,
                 stiffness_n_per_m: float = 3000.0, ambient_pa: float = 100_900.0,
                 pad: PadResponse | None = None, body_in_imu_wxyz=(1.0, 0.0, 0.0, 0.0)):
        if not stiffness_n_per_m > 0.0:
            raise ValueError(f"stiffness_n_per_m must be > 0, got {stiffness_n_per_m}")
        if not ambient_pa > 0.0:
            raise ValueError(f"ambient_pa must be > 0 Pa, got {ambient_pa}")
        if kinematics.dof != controller.dof:
            raise ValueError(f"kinematics has {kinematics.dof} joints, the controller {controller.dof}")
        self.controller = controller
        self.kinematics = kinematics
        self.barometer_chip = barometer_chip
        self.imu_chip = imu_chip
        self.clock = clock
        self.sphere = sphere
        self.stiffness_n_per_m = float(stiffness_n_per_m)
        self.ambient_pa = float(ambient_pa)
        self.pad = pad or PadResponse()
        self._imu_in_body = rotation_from_wxyz(np.asarray(body_in_imu_wxyz, float)).inv()
        self.max_force_n = 0.0
        self._pivot_to_pad = kinematics.pivot_to_pad_in_body
        self.state = self.update()

    def sleep(self, seconds: float) -> None:
        """Let ``seconds`` pass on the clock, then update the chips."""
        self.clock.sleep(seconds)
        self.update()

    def pad_state(self, q: np.ndarray) -> TouchState:
        """Pad pose, force and pressure for joint angles ``q`` ((dof,) radians), without touching the chips."""
        spec = self.kinematics.spec
        # one configuration per control tick: the numpy path, not the batched torch one (ms per call)
        pivot, _ = self.kinematics.pose_of_one(q, spec.pivot_link)
        _, commanded = self.kinematics.pose_of_one(q, spec.sensor_body_link)
        free_pad = pivot + commanded @ self._pivot_to_pad
        t_s = self.clock.monotonic()
        free = TouchState(t_s, free_pad, commanded, 0.0, 0.0, self.ambient_pa, None)
        reach = float(np.linalg.norm(self._pivot_to_pad))
        if np.linalg.norm(pivot - self.sphere.centre_m) > self.sphere.radius_m + reach:
            return free
        normal = self.sphere.outward_normal(free_pad)
        body = aligned_rotation(commanded, normal)
        pad_position = pivot + body @ self._pivot_to_pad
        normal = self.sphere.outward_normal(pad_position)  # once more from the aligned pad
        body = aligned_rotation(commanded, normal)
        pad_position = pivot + body @ self._pivot_to_pad
        depth = self.sphere.penetration_m(pad_position)
        if depth <= 0.0:
            return free
        force = self.stiffness_n_per_m * depth
        pressure = self.ambient_pa + float(self.pad.pressure_rise_pa(force))
        return TouchState(t_s, pad_position, body, depth, force, pressure, normal)

    def update(self) -> TouchState:
        """Set the chips from the controller's true joint angles now."""
        state = self.pad_state(self.controller.true_q)
        self.barometer_chip.pressure_pa = state.pressure_pa
        imu = Rotation.from_matrix(state.body_rotation) * self._imu_in_body
        self.imu_chip.quat_wxyz = wxyz_from_rotation(imu)
        self.imu_chip.gravity_mps2 = imu.inv().apply([0.0, 0.0, GRAVITY_MPS2])
        self.imu_chip.lin_acc_mps2 = np.zeros(3)
        self.max_force_n = max(self.max_force_n, state.force_n)
        self.state = state
        return state


@dataclass
class EmulatedRig:
    """The hardware backend on emulators, touching a virtual sphere.

    Attributes
    ----------
    arm : robots.hardware.SerialArm
        Not yet open.
    sensor : sensor.drivers.HardwareTactileSensor
        Not yet open; polls in ``read``/``drain``.
    world : ContactWorld
    clock : FakeClock
    controller : EmulatedArmController
    bus : FakeSMBus
        The chips' I2C bus (``bus.faults`` injects sensor faults).
    port : FakeArmSerial
        The arm's serial link (``port.faults`` injects link and controller faults).
    """

    arm: object
    sensor: object
    world: ContactWorld
    clock: FakeClock
    controller: EmulatedArmController = field(repr=False)
    bus: FakeSMBus = field(repr=False, default=None)
    port: FakeArmSerial = field(repr=False, default=None)


def emulated_rig(spec, sphere: VirtualSphere, *, kinematics: ArmKinematics | None = None,
                 clock: FakeClock | None = None, noise_pa: float = 2.0, seed: int = 0,
                 encoder_resolution_rad: float | None = None, **world_options) -> EmulatedRig:
    """SerialArm + HardwareTactileSensor on emulators sharing one FakeClock, coupled by a :class:`ContactWorld`.

    The arm sleeps through :meth:`ContactWorld.sleep`, so each control tick moves the emulated
    joints and then sets the chips; the sensor's readings are stamped with the same clock.
    """
    from robots.hardware import SerialArm
    from sensor.drivers.bmp280 import BMP280
    from sensor.drivers.bno055 import BNO055I2C
    from sensor.drivers.hardware_sensor import HardwareTactileSensor

    clock = clock or FakeClock()
    kinematics = kinematics or ArmKinematics(spec)
    controller_options = {} if encoder_resolution_rad is None else dict(encoder_resolution_rad=encoder_resolution_rad)
    controller = EmulatedArmController.for_spec(spec, clock=clock.monotonic, **controller_options)
    barometer_chip = BMP280Chip(pressure_pa=world_options.get("ambient_pa", 100_900.0), noise_pa=noise_pa, seed=seed)
    imu_chip = BNO055Chip(clock=clock.monotonic)
    world = ContactWorld(controller, kinematics, barometer_chip, imu_chip, clock, sphere, **world_options)
    bus = FakeSMBus({BMP280_ADDRESS: barometer_chip, BNO055_ADDRESS: imu_chip})
    barometer = BMP280(bus, BMP280_ADDRESS, sleep=clock.sleep, clock=clock.monotonic)
    imu = BNO055I2C(bus, BNO055_ADDRESS, sleep=clock.sleep, clock=clock.monotonic)
    sensor = HardwareTactileSensor.from_chips(barometer, imu, clock=clock.monotonic, sleep=world.sleep)
    port = FakeArmSerial(controller, clock=clock)
    arm = SerialArm(port, spec, clock=clock.monotonic, sleep=world.sleep)
    return EmulatedRig(arm, sensor, world, clock, controller, bus, port)


__all__ = ["VirtualSphere", "TouchState", "ContactWorld", "EmulatedRig", "aligned_rotation", "emulated_rig"]
