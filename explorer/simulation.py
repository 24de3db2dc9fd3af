"""The simulated backend: a PyBullet world with the arm, the fingertip sensor, the object on a stand.

Everything the exploration loop needs, built from registry names; the loop itself only sees the
Robot, TactileSensor and Positioner interfaces.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

import objects
import robots
from explorer.positioner import SimulatedStand, turntable_poses
from robots.kinematics import ArmKinematics
from robots.pad_compliance import measure_pad_compliance_m_per_n, measure_pad_point_compliance_m_per_n
from robots.sim_arm import SimArm
from robots.sim_world import SimWorld
from sensor.pad_calibration import PAD_STIFFNESS_N_PER_M, PadCalibration
from explorer.sim_profile import SimProfile, get_profile
from sensor.sim_sensor import SimulatedSensorConfig, SimulatedTactileSensor



@dataclass
class SimScene:
    """A simulated setup; close it (or use it as a context manager) to release the simulator.

    Attributes
    ----------
    world : SimWorld
    arm : SimArm
    sensor : SimulatedTactileSensor
    kinematics : ArmKinematics
    stand : SimulatedStand
    object_model : objects.ObjectModel
        Ground truth (object frame).
    pad : PadCalibration
        The simulated pad's own force model and its compliance measured on a flat plate and on one
        point (:mod:`robots.pad_compliance`), as a lab calibrates a real pad's.
    profile : SimProfile
        The errors this scene simulates.
    """

    world: SimWorld
    arm: SimArm
    sensor: SimulatedTactileSensor
    kinematics: ArmKinematics
    stand: SimulatedStand
    object_model: "objects.ObjectModel"
    pad: PadCalibration
    profile: SimProfile = get_profile(None)

    def close(self) -> None:
        self.sensor.close()
        self.world.close()

    def __enter__(self) -> "SimScene":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def build_scene(object_name: str, robot_name: str = "armar3", seed: int = 0, gui: bool = False,
                sensor_config: SimulatedSensorConfig | None = None, yaw_steps: int = 12,
                tilt_steps: int = 4, stand_centre_m=None,
                pad_stiffness_n_per_m: float = PAD_STIFFNESS_N_PER_M,
                profile: str | SimProfile | None = None) -> SimScene:
    """Load the robot, the object on a turntable-and-tilt stand at the arm's workspace centre,
    and the simulated sensor wired to the pad.

    Parameters
    ----------
    object_name : str
        Registry name or mesh file (metres, object frame).
    robot_name : str
        Robot registry name.
    seed : int
        Seeds the sensor noise and the encoder model (and the profile's calibration errors).
    sensor_config : SimulatedSensorConfig, optional
        Overrides the profile's sensor settings.
    profile : str or SimProfile, optional
        Simulation profile name, TOML file or object (default ``datasheet-noise``,
        :mod:`explorer.sim_profile`): spring friction, pad friction, encoders, calibration errors, chips.
    stand_centre_m : (3,) float, optional
        Where the object-frame origin sits in the world (default: the robot's workspace centre).
    pad_stiffness_n_per_m : float
        The simulated pad's contact stiffness per contact point (PyBullet's), N/m, unless the
        profile sets it; the loop's compliance is measured from the resulting pad.
    """
    profile = get_profile(profile)
    model = objects.load(object_name)
    spec = profile.robot_spec(dataclasses.replace(robots.load(robot_name),
                                                  pad_contact_stiffness_n_per_m=pad_stiffness_n_per_m))
    sensor_config = profile.sensor_config() if sensor_config is None else sensor_config
    world = SimWorld(gui=gui)
    try:
        centre = np.asarray(spec.workspace_center_m if stand_centre_m is None else stand_centre_m, float)
        handle = world.add_object(model.urdf_path, centre, name=model.name)
        stand = SimulatedStand(lambda p, q: world.set_object_pose(handle, p, q), centre,
                               turntable_poses(yaw_steps, tilt_steps))
        arm = SimArm(world, spec, encoder=profile.encoder_model(spec.dof, seed),
                     spring_friction_nm=profile.spring_friction_nm,
                     link_length_error_m=profile.link_length_errors_m(spec, seed))
        sensor = SimulatedTactileSensor(config=sensor_config, seed=seed)
        connect_sensor(world, arm, sensor)
        sensor.open()
        pad = PadCalibration(sensor.config.barometer.pad, measure_pad_compliance_m_per_n(spec),
                             spring_stiffness_nm_per_rad=spec.spring_stiffness_nm_per_rad,
                             point_compliance_m_per_n=measure_pad_point_compliance_m_per_n(spec))
        return SimScene(world, arm, sensor, ArmKinematics(spec), stand, model, pad, profile)
    except Exception:
        world.close()
        raise


def connect_sensor(world: SimWorld, arm: SimArm, sensor: SimulatedTactileSensor) -> None:
    """Feed ``sensor`` the pad's state after every physics step of ``world``.

    The whole :class:`common.PadState` (link pose and velocity queries) only on the steps where
    the sensor needs it (IMU samples); on the others the pad's normal force alone, which is all
    the chips read there: the same readings at a fraction of the per-step cost.
    """
    def on_step(_t_s: float) -> None:
        t_s = world.time_s
        if sensor.needs_pad_state(t_s):
            sensor.on_step(arm.pad_state())
        else:
            sensor.on_force_step(t_s, arm.pad_normal_force_n())

    world.add_step_listener(on_step)
