"""A rig from a configuration file: the configured robot and sensor, the object's rough location,
and the reference surface when one is known, ready for :func:`explorer.run.run_on_rig`.

On a rig the object stays where it is (:class:`FixedStand` at ``object.centre_m``); a motorised
turntable would be another :class:`explorer.positioner.Positioner`. The same path serves all
backends: ``sim`` (PyBullet, the registry object on a stand that does not turn), ``emulated``
(emulators pressed against a virtual sphere) and the hardware ones.
"""
from __future__ import annotations

import contextlib
from typing import Iterator

import numpy as np

from explorer.config import BackendConfig, load_calibration, open_backends
from explorer.positioner import FixedStand
from explorer.run import PRIOR_GROWTH, PRIOR_MARGIN_M, Rig, RunSettings, object_prior
from explorer.touch import ObjectPrior


def run_settings(config: BackendConfig) -> RunSettings:
    """The run settings of ``config`` (``[exploration]``, the object's name, the robot)."""
    exploration = config.exploration
    return RunSettings(object=config.object.name, robot=config.robot.spec, strategy=exploration.strategy,
                       touches=exploration.touches, seed=exploration.seed, use_normals=exploration.use_normals,
                       eval_every=exploration.eval_every, mesh_resolution=exploration.mesh_resolution,
                       profile=config.simulation.profile if config.robot.backend == "sim" else "none")


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
    alignment = None if calibration is None else calibration.imu_alignment()
    with open_backends(config, sim_builder=_simulated_backends) as (robot, sensor):
        description = dict(robot=spec.name, sensor=_sensor_description(config), object=config.object.name,
                           backend=f"robot {config.robot.backend}, sensor {config.sensor.backend}")
        if config.sensor.calibration is not None:
            description["sensor_calibration"] = str(config.sensor.calibration)
        yield Rig(robot, sensor, ArmKinematics(spec), FixedStand(centre), prior, reference, description,
                  alignment)


def _reference(config: BackendConfig):
    """The true surface in the object frame: the given mesh, the simulated object, the emulated sphere."""
    import trimesh

    if config.object.reference_mesh is not None:
        path = config.object.reference_mesh
        if not path.exists():
            raise FileNotFoundError(f"object.reference_mesh: {path} does not exist")
        return trimesh.load(path, force="mesh")
    if config.robot.backend == "sim":
        import objects
        return objects.load(config.object.name).mesh
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

    with build_scene(config.object.name, config.robot.spec, seed=config.exploration.seed,
                     stand_centre_m=config.object.centre_m, yaw_steps=1, tilt_steps=1,
                     profile=config.simulation.profile) as scene:
        yield scene.arm, scene.sensor
