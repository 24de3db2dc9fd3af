"""Opening what a configuration file describes (:mod:`explorer.config` is its schema): the devices
(:func:`open_backends`, :func:`open_robot`, :func:`open_sensor`) and a whole rig (:func:`open_rig`):
the configured robot and sensor, the object's rough location, the sensor's pad calibration and the
reference surface when one is known, ready for :func:`explorer.run.run_on_rig`.

The simulated backends (``backend = "sim"``) are built by a callable passed in
(:func:`open_sim_backends`), so opening hardware needs neither PyBullet nor, until a device is
opened, the hardware packages.

On a rig the object stays where it is (:class:`FixedStand` at ``object.centre_m``); a motorised
turntable would be another :class:`explorer.positioner.Positioner`. The same path serves all
backends: ``sim`` (PyBullet, the registry object on a stand that does not turn), ``emulated``
(emulators pressed against a virtual sphere) and the hardware ones.
"""
from __future__ import annotations

import contextlib
import time
from typing import Any, Callable, ContextManager, Iterator

import numpy as np

from explorer.config import BackendConfig, RobotConfig, SensorConfig
from explorer.positioner import FixedStand
from explorer.planner import PlannerConfig
from explorer.rig import PRIOR_GROWTH, PRIOR_MARGIN_M, Rig, object_prior
from explorer.run import RunSettings
from explorer.touch import ObjectPrior
from sensor.pad_calibration import PadCalibration

#: Builds the simulated (robot, sensor) of a configuration, as a context manager.
SimBuilder = Callable[[BackendConfig], ContextManager[tuple[Any, Any]]]


def object_name(config: BackendConfig) -> str:
    """The object to load: ``object.name``, or for a mesh file in simulation its copy in metres
    (``object.units``, see :func:`objects.in_metres`)."""
    import objects

    name = config.object.name
    if config.robot.backend != "sim" or not objects.is_mesh_file_name(name):
        return name
    try:
        return objects.in_metres(name, config.object.units)
    except ValueError as error:
        raise ValueError(f"object.name: {_config_units_hint(error)}") from error


def _config_units_hint(error: Exception) -> str:
    """A loader message with its command-line advice (``--units mm``) said as the config key."""
    return str(error).replace("pass --units ", "set object.units = ").replace("with --units", "with object.units")


def run_settings(config: BackendConfig) -> RunSettings:
    """The run settings of ``config`` (``[exploration]``, the object's name, the robot)."""
    exploration = config.exploration
    return RunSettings(object=object_name(config), robot=config.robot.spec, strategy=exploration.strategy,
                       touches=exploration.touches, seed=exploration.seed, use_normals=exploration.use_normals,
                       eval_every=exploration.eval_every, mesh_resolution=exploration.mesh_resolution,
                       reach_samples=exploration.reach_samples,
                       profile=config.simulation.profile if config.robot.backend == "sim" else "none",
                       planner=PlannerConfig(probe_depth_m=exploration.probe_depth_m))


@contextlib.contextmanager
def open_rig(config: BackendConfig) -> Iterator[Rig]:
    """Open the configured devices and describe the rig; closes the devices on exit.

    Raises
    ------
    ValueError
        Hardware without ``object.half_extent_m`` (the loop needs the object's rough size).
    """
    import robots
    from robots.kinematics import ArmKinematics

    spec = robots.load(config.robot.spec)
    centre = np.asarray(config.object.centre_m or spec.workspace_center_m, float)
    reference = _reference(config)
    prior = _prior(config, reference)
    calibration = load_calibration(config.sensor)
    pad = PadCalibration() if calibration is None else calibration.pad_calibration()
    with open_backends(config, sim_builder=_simulated_backends) as (robot, sensor):
        description = dict(robot=spec.name, sensor=_sensor_description(config), object=config.object.name,
                           backend=f"robot {config.robot.backend}, sensor {config.sensor.backend}")
        if config.sensor.calibration is not None:
            description["sensor_calibration"] = str(config.sensor.calibration)
        yield Rig(robot, sensor, ArmKinematics(spec), FixedStand(centre), prior, reference, description, pad,
                  obstacles=_obstacles(config))


def _obstacles(config: BackendConfig) -> tuple:
    """The configured fixed obstacles as (centre, half extent) pairs, and the simulated table."""
    boxes = tuple((box[:3], box[3:]) for box in config.robot.obstacles_m)
    if config.robot.backend == "sim":
        from robots.sim_world import TableSpec

        boxes += (TableSpec().box_m(),)
    return boxes


def _reference(config: BackendConfig):
    """The true surface in the object frame: the given mesh, the simulated object, the emulated sphere."""
    import trimesh

    import objects

    if config.object.reference_mesh is not None:
        path = config.object.reference_mesh
        if not path.exists():
            raise FileNotFoundError(f"object.reference_mesh: {path} does not exist")
        try:
            # registered to a real object's frame: never moved to its centre (in simulation it is in the
            # frame of the simulated object, which is)
            return objects.load(path, scale=objects.units_scale(config.object.units),
                                keep_frame=config.robot.backend != "sim").mesh
        except ValueError as error:
            raise ValueError(f"object.reference_mesh: {_config_units_hint(error)}") from error
    if config.robot.backend == "sim":
        return objects.load(object_name(config)).mesh
    if config.robot.backend == "emulated":
        sphere = trimesh.creation.icosphere(subdivisions=4, radius=config.emulation.sphere_radius_m)
        sphere.apply_translation(config.emulation.sphere_offset_m)
        return sphere
    return None


def _prior(config: BackendConfig, reference) -> ObjectPrior:
    if config.object.half_extent_m is not None:
        return ObjectPrior(np.zeros(3), np.asarray(config.object.half_extent_m, float))
    if config.robot.backend == "serial":
        raise ValueError("object.half_extent_m: required on hardware (the object's rough half size in metres, "
                         "e.g. [0.06, 0.06, 0.08]); the loop only explores inside that box")
    if config.robot.backend == "sim":
        return object_prior(reference)
    # emulated: a box around the sphere, centred where the object was said to be
    lo, hi = reference.bounds
    half = np.maximum(np.abs(lo), np.abs(hi))
    return ObjectPrior(np.zeros(3), half * (1 + PRIOR_GROWTH) + PRIOR_MARGIN_M)


def _sensor_description(config: BackendConfig) -> str:
    sensor = config.sensor
    return {"sim": "simulated BNO055 + BMP280 under polyurethane",
            "emulated": "emulated BNO055 + BMP280 (register-level) on a fake I2C bus",
            "i2c": f"BNO055 0x{sensor.bno055_address:02X} + BMP280 0x{sensor.bmp280_address:02X} on I2C bus {sensor.bus}",
            "uart": f"BNO055 on {sensor.port} + BMP280 on I2C bus {sensor.bus}",
            "mcu": f"BNO055 + BMP280 behind a microcontroller on {sensor.port}"}[sensor.backend]


@contextlib.contextmanager
def _simulated_backends(config: BackendConfig):
    """The simulated arm and sensor with the object fixed at ``object.centre_m``."""
    from explorer.simulation import build_scene

    with build_scene(object_name(config), config.robot.spec, seed=config.exploration.seed,
                     stand_centre_m=config.object.centre_m, yaw_steps=1, tilt_steps=1,
                     profile=config.simulation.profile) as scene:
        yield scene.arm, scene.sensor


# ---- opening devices -----------------------------------------------------------------------

def load_calibration(config: SensorConfig):
    """The :class:`sensor.calibration.SensorCalibration` the config refers to, or None."""
    if config.calibration is None:
        return None
    from sensor.calibration import SensorCalibration
    return SensorCalibration.load(config.calibration)


@contextlib.contextmanager
def open_robot(config: RobotConfig, *, clock: Callable[[], float] = time.monotonic,
               sleep: Callable[[float], None] = time.sleep) -> Iterator[Any]:
    """Open the hardware arm of ``config`` (``backend = "serial"``); yields a :class:`robots.interface.Robot`."""
    if config.backend != "serial":
        raise ValueError(f"robot.backend = {config.backend!r} is not a hardware backend: use open_backends() "
                         f"with a sim_builder for the simulation")
    from robots.hardware import SerialArm
    arm = SerialArm(config.port, config.spec, baudrate=config.baudrate, reply_timeout_s=config.reply_timeout_s,
                    attempts=config.attempts, control_rate_hz=config.control_rate_hz, clock=clock, sleep=sleep)
    with arm:
        yield arm


@contextlib.contextmanager
def open_sensor(config: SensorConfig, *, clock: Callable[[], float] = time.monotonic,
                sleep: Callable[[float], None] = time.sleep,
                open_i2c_bus: Callable[[int], Any] | None = None) -> Iterator[Any]:
    """Open the hardware (or emulated) sensor of ``config``; yields an open :class:`sensor.interface.TactileSensor`.

    ``open_i2c_bus(bus_number)`` returns an smbus2-like bus (default ``smbus2.SMBus``); the bus and
    serial ports opened here are closed on exit.
    """
    if config.backend == "sim":
        raise ValueError("sensor.backend = 'sim' is not a hardware backend: use open_backends() with a sim_builder")
    with contextlib.ExitStack() as stack:
        sensor = _build_sensor(config, stack, clock, sleep, open_i2c_bus)
        stack.enter_context(sensor)
        yield sensor


def _build_sensor(config: SensorConfig, stack: contextlib.ExitStack, clock, sleep, open_i2c_bus):
    from sensor.drivers import (BMP280, BNO055I2C, BNO055UART, CalibrationProfile, HardwareTactileSensor,
                                MicrocontrollerStream, OperationMode)
    if config.backend == "emulated":
        from sensor.emulated_fingertip import PressScript, emulated_fingertip
        return emulated_fingertip(PressScript.regular(20), clock=clock, sleep=sleep)
    calibration = load_calibration(config)
    options = dict(read_timeout_s=config.read_timeout_s, sleep=sleep)
    if config.backend == "mcu":
        port = stack.enter_context(contextlib.closing(_open_serial(config.port, config.baudrate)))
        return HardwareTactileSensor.from_stream(MicrocontrollerStream(port, clock=clock), **options)
    bus = stack.enter_context(contextlib.closing(_open_i2c(config.bus, open_i2c_bus)))
    barometer = BMP280(bus, config.bmp280_address, sleep=sleep, clock=clock)
    if config.backend == "i2c":
        imu = BNO055I2C(bus, config.bno055_address, sleep=sleep, clock=clock)
    else:
        port = stack.enter_context(contextlib.closing(_open_serial(config.port, config.baudrate)))
        imu = BNO055UART(port, sleep=sleep, clock=clock)
    if calibration is not None and calibration.bno055_profile_hex:
        imu.write_calibration(CalibrationProfile.from_hex(calibration.bno055_profile_hex))
    return HardwareTactileSensor.from_chips(barometer, imu, imu_mode=OperationMode[config.imu_mode], clock=clock,
                                            **options)


def _open_i2c(bus_number: int, open_i2c_bus: Callable[[int], Any] | None):
    from sensor.drivers import DeviceDisconnectedError
    if open_i2c_bus is None:
        try:
            from smbus2 import SMBus
        except ImportError as error:
            raise ImportError("the I2C sensor backends need smbus2: pip install smbus2 (or the project's "
                              "[hardware] extra)") from error
        open_i2c_bus = SMBus
    try:
        return open_i2c_bus(bus_number)
    except OSError as error:
        raise DeviceDisconnectedError(f"I2C bus {bus_number}", f"cannot open /dev/i2c-{bus_number}: {error} "
                                                               f"(I2C enabled? user in the i2c group?)") from error


def _open_serial(port: str, baudrate: int):
    from sensor.drivers import DeviceDisconnectedError
    try:
        import serial
    except ImportError as error:
        raise ImportError("the serial sensor backends need pyserial: pip install pyserial (or the project's "
                          "[hardware] extra)") from error
    if "emu://" in port:
        from sensor.emulators import register_serial_url_handlers
        register_serial_url_handlers()
    try:
        return serial.serial_for_url(port, baudrate=baudrate, timeout=0.02)
    except (OSError, ValueError) as error:
        raise DeviceDisconnectedError(f"serial port {port}", f"cannot open: {error}") from error


@contextlib.contextmanager
def open_sim_backends(config: BackendConfig, sim_builder: SimBuilder | None) -> Iterator[tuple[Any, Any]]:
    """The simulated robot and sensor, built by ``sim_builder(config)`` (the explorer provides it)."""
    if sim_builder is None:
        raise NotImplementedError(
            "backend = 'sim' is built by the explorer's simulation (explorer.simulation.build_scene): pass "
            "open_backends(config, sim_builder=...), a callable taking the BackendConfig and returning a context "
            "manager that yields (robot, sensor)")
    with sim_builder(config) as (robot, sensor):
        yield robot, sensor


@contextlib.contextmanager
def open_backends(config: BackendConfig, *, sim_builder: SimBuilder | None = None,
                  clock: Callable[[], float] = time.monotonic, sleep: Callable[[float], None] = time.sleep,
                  open_i2c_bus: Callable[[int], Any] | None = None) -> Iterator[tuple[Any, Any]]:
    """Open the robot and the sensor of ``config``; yields ``(robot, sensor)`` and closes both on exit.

    The robot is opened first and closed last. Simulation and hardware do not mix: ``"sim"`` must
    be chosen for both or neither. ``robot.backend = "emulated"`` runs on emulators in virtual
    time (``clock``, ``sleep`` and ``open_i2c_bus`` are not used).
    """
    if config.robot.backend == "emulated":
        with open_emulated_backends(config) as pair:
            yield pair
        return
    sim = (config.robot.backend == "sim", config.sensor.backend == "sim")
    if any(sim):
        if not all(sim):
            raise ValueError(f"robot.backend = {config.robot.backend!r} and sensor.backend = "
                             f"{config.sensor.backend!r}: the simulated robot and sensor only exist together; "
                             f"set both to 'sim' or neither")
        with open_sim_backends(config, sim_builder) as pair:
            yield pair
        return
    with contextlib.ExitStack() as stack:
        robot = stack.enter_context(open_robot(config.robot, clock=clock, sleep=sleep))
        sensor = stack.enter_context(open_sensor(config.sensor, clock=clock, sleep=sleep,
                                                 open_i2c_bus=open_i2c_bus))
        yield robot, sensor


@contextlib.contextmanager
def open_emulated_backends(config: BackendConfig) -> Iterator[tuple[Any, Any]]:
    """A :class:`robots.hardware.SerialArm` and a :class:`sensor.drivers.HardwareTactileSensor` on
    emulators, coupled through a virtual sphere (``[emulation]``) at ``object.centre_m`` plus
    ``emulation.sphere_offset_m``; both run on one virtual clock. Yields ``(robot, sensor)``."""
    import numpy as np

    import robots
    from explorer.contact_world import VirtualSphere, emulated_rig

    spec = robots.load(config.robot.spec)
    centre = np.asarray(config.object.centre_m or spec.workspace_center_m, float)
    sphere = VirtualSphere(centre + np.asarray(config.emulation.sphere_offset_m), config.emulation.sphere_radius_m)
    rig = emulated_rig(spec, sphere, noise_pa=config.emulation.noise_pa, seed=config.emulation.seed)
    with rig.arm, rig.sensor:
        yield rig.arm, rig.sensor
