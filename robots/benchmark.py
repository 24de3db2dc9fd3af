"""Simulation speed while the arm presses an object (used by scripts/robot_speed_benchmark.py).

The object stands on the default table at the robot's workspace centre: a primitive box of our
own, or a registry object from ``objects`` (triangle-mesh collision). The arm presses a reachable
surface point along its normal to 5 N, holds 0.25 s, backs off 3 cm and repeats.
"""
from __future__ import annotations

import os
import platform
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from robots.ik import IKOptions, solve_pad_ik
from robots.kinematics import ArmKinematics
from robots.registry import load
from robots.sim_arm import SimArm
from robots.sim_world import SimWorld, TableSpec
from robots.urdf_model import Box, Link, RobotModel, Shape, to_urdf

PRIMITIVE_BOX_M = (0.12, 0.10, 0.15)
PRESS_FORCE_N = 5.0
STANDOFF_M = 0.03


@dataclass(frozen=True)
class SpeedFigures:
    """Simulated seconds per wall-clock second for one robot and object.

    Attributes
    ----------
    robot, object_name : str
    time_step_s : float
    with_listener_realtime_factor : float
        With a step listener reading ``pad_state()`` after every physics step (the most a
        simulated sensor can cost).
    realtime_factor : float
        The same press cycles without the listener.
    simulated_s : float
        Simulated duration of each measurement, seconds.
    mean_press_force_n : float
        Mean pad force while in contact (shows that the arm really pressed).
    """

    robot: str
    object_name: str
    time_step_s: float
    with_listener_realtime_factor: float
    realtime_factor: float
    simulated_s: float
    mean_press_force_n: float


def machine_description() -> str:
    """One line naming the machine the figures come from."""
    import pybullet

    return (f"{platform.node()}: {platform.machine()} {platform.processor()} {os.cpu_count()} CPUs, "
            f"Python {platform.python_version()}, pybullet API {pybullet.getAPIVersion()}").replace("  ", " ")


def _object(name: str | None, directory: Path):
    """(urdf path, trimesh mesh in the object frame, label) of the object to press."""
    import trimesh

    if name is None:
        path = directory / "benchmark_box.urdf"
        path.write_text(to_urdf(RobotModel("box", (Link("box", 1.0, shapes=(Shape(Box(PRIMITIVE_BOX_M)),)),))))
        return path, trimesh.creation.box(PRIMITIVE_BOX_M), "primitive box"
    import objects

    model = objects.load(name)
    return model.urdf_path, model.mesh, f"objects '{name}' (mesh, {len(model.mesh.faces)} faces)"


def _press_line(kinematics: ArmKinematics, mesh, position: np.ndarray) -> np.ndarray:
    """Joint path from STANDOFF_M outside a reachable surface point to 1 cm inside it."""
    import trimesh

    points, faces = trimesh.sample.sample_surface(mesh, 100, seed=0)
    points = points + position
    normals = mesh.face_normals[faces]
    standoff = solve_pad_ik(kinematics, points + STANDOFF_M * normals, -normals, options=IKOptions(max_rounds=1))
    for index in np.flatnonzero(standoff.success):
        depths = np.linspace(STANDOFF_M, -0.01, 9)
        line = points[index] + depths[:, None] * normals[index]
        path = solve_pad_ik(kinematics, line, np.tile(-normals[index], (len(line), 1)), q_seed=standoff.q_rad[index])
        if path.success.all() and np.abs(np.diff(path.q_rad, axis=0)).max() < 0.2:
            return path.q_rad
    raise RuntimeError("no reachable press line on the benchmark object")


def measure(robot: str = "armar3", seconds: float = 10.0, time_step_s: float | None = None,
            object_name: str | None = None) -> SpeedFigures:
    """Real-time factors of :class:`SimWorld` + :class:`SimArm` pressing an object, DIRECT mode."""
    spec = load(robot)
    kinematics = ArmKinematics(spec)
    table = TableSpec()
    options = {} if time_step_s is None else {"time_step_s": time_step_s}
    factors, forces = [], []
    with tempfile.TemporaryDirectory() as tmp:
        urdf, mesh, label = _object(object_name, Path(tmp))
        centre = np.array(spec.workspace_center_m)
        position = np.array([centre[0], centre[1], table.height_m - mesh.bounds[0][2]])
        path = _press_line(kinematics, mesh, position)
        for with_listener in (True, False):
            with SimWorld(table=table, **options) as world:
                arm = SimArm(world, spec)
                world.add_object(urdf, position)
                arm.reset_joint_positions(path[0])
                if with_listener:
                    world.add_step_listener(lambda t: arm.pad_state())
                start = time.perf_counter()
                while world.time_s < seconds:
                    arm.guarded_move(path[1:], lambda: arm.pad_state().normal_force_n > PRESS_FORCE_N,
                                     speed_rad_s=0.05)
                    hold_until = world.time_s + 0.25
                    while world.time_s < hold_until:
                        world.step(arm.control_steps)
                        forces.append(arm.pad_state().normal_force_n)
                    arm.guarded_move(path[:1], lambda: False, speed_rad_s=0.2)
                factors.append(world.time_s / (time.perf_counter() - start))
                dt = world.time_step_s
    pressing = [f for f in forces if f > 0.0]
    return SpeedFigures(robot, label, dt, factors[0], factors[1], seconds,
                        float(np.mean(pressing)) if pressing else 0.0)
