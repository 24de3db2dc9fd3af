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


class PressCycles:
    """The benchmark's press cycles, ready to run in bursts (a context manager).

    Builds the world (table, object, arm at the start of a reachable press line) once;
    :meth:`run` then presses for a number of simulated seconds and returns the wall time it took,
    so bare-physics bursts can be interleaved with other work measured under the same load.

    Parameters
    ----------
    robot, object_name, time_step_s : as :func:`measure`
    listener : bool
        Read ``pad_state()`` after every physics step.
    """

    def __init__(self, robot: str = "armar3", object_name: str | None = None, time_step_s: float | None = None,
                 listener: bool = False):
        spec = load(robot)
        kinematics = ArmKinematics(spec)
        table = TableSpec()
        self._tmp = tempfile.TemporaryDirectory()
        urdf, mesh, self.label = _object(object_name, Path(self._tmp.name))
        centre = np.array(spec.workspace_center_m)
        position = np.array([centre[0], centre[1], table.height_m - mesh.bounds[0][2]])
        self._path = _press_line(kinematics, mesh, position)
        options = {} if time_step_s is None else {"time_step_s": time_step_s}
        self.world = SimWorld(table=table, **options)
        self.arm = SimArm(self.world, spec)
        self.world.add_object(urdf, position)
        self.arm.reset_joint_positions(self._path[0])
        if listener:
            self.world.add_step_listener(lambda t: self.arm.pad_state())
        self.forces: list[float] = []

    def run(self, seconds: float) -> float:
        """Press for at least ``seconds`` simulated (whole cycles); return the wall seconds taken."""
        world, arm, path = self.world, self.arm, self._path
        end = world.time_s + seconds
        start = time.perf_counter()
        while world.time_s < end:
            arm.guarded_move(path[1:], lambda: arm.pad_state().normal_force_n > PRESS_FORCE_N, speed_rad_s=0.05)
            hold_until = world.time_s + 0.25
            while world.time_s < hold_until:
                world.step(arm.control_steps)
                self.forces.append(arm.pad_state().normal_force_n)
            arm.guarded_move(path[:1], lambda: False, speed_rad_s=0.2)
        return time.perf_counter() - start

    def close(self) -> None:
        self.world.close()
        self._tmp.cleanup()

    def __enter__(self) -> "PressCycles":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def measure(robot: str = "armar3", seconds: float = 10.0, time_step_s: float | None = None,
            object_name: str | None = None) -> SpeedFigures:
    """Real-time factors of :class:`SimWorld` + :class:`SimArm` pressing an object, DIRECT mode."""
    factors, forces = [], []
    for with_listener in (True, False):
        with PressCycles(robot, object_name, time_step_s, listener=with_listener) as bench:
            wall = bench.run(seconds)
            factors.append(bench.world.time_s / wall)
            forces += bench.forces
            dt, label = bench.world.time_step_s, bench.label
    pressing = [f for f in forces if f > 0.0]
    return SpeedFigures(robot, label, dt, factors[0], factors[1], seconds,
                        float(np.mean(pressing)) if pressing else 0.0)
