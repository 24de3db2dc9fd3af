"""Simulation speed while the arm presses an object (used by scripts/robot_speed_benchmark.py)."""
from __future__ import annotations

import math
import platform
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from robots.ik import solve_pad_ik
from robots.kinematics import ArmKinematics
from robots.registry import load
from robots.rotations import matrix_to_quat
from robots.sim_arm import SimArm
from robots.sim_world import SimWorld
from robots.urdf_model import Box, Link, RobotModel, Shape, to_urdf

BOX_SIZE_M = (0.2, 0.2, 0.1)


@dataclass(frozen=True)
class SpeedFigures:
    """Simulated seconds per wall-clock second for one robot.

    Attributes
    ----------
    robot : str
    time_step_s : float
    pressing_realtime_factor : float
        While pressing and releasing the object repeatedly, with a step listener reading
        ``pad_state()`` after every physics step (what a simulated sensor costs at most).
    pressing_no_listener_realtime_factor : float
        The same motion without the listener.
    simulated_s : float
        Simulated duration of each measurement, seconds.
    mean_normal_force_n : float
        Mean pad force over the pressing phases (shows that the arm really pressed).
    """

    robot: str
    time_step_s: float
    pressing_realtime_factor: float
    pressing_no_listener_realtime_factor: float
    simulated_s: float
    mean_normal_force_n: float


def machine_description() -> str:
    """One line naming the machine the figures come from."""
    import os

    import pybullet

    return (f"{platform.node()}: {platform.machine()} {platform.processor() or ''} {os.cpu_count()} CPUs, "
            f"Python {platform.python_version()}, pybullet API {pybullet.getAPIVersion()}").replace("  ", " ")


def _box_urdf(directory: Path) -> Path:
    path = directory / "benchmark_box.urdf"
    path.write_text(to_urdf(RobotModel("box", (Link("box", 1.0, shapes=(Shape(Box(BOX_SIZE_M)),)),))))
    return path


def _press_cycles(world: SimWorld, arm: SimArm, press_path: np.ndarray, home_q: np.ndarray, seconds: float,
                  forces: list[float]) -> float:
    """Press into the box and back until ``seconds`` of simulation have passed; wall time used."""
    start_sim, start_wall = world.time_s, time.perf_counter()
    while world.time_s - start_sim < seconds:
        arm.guarded_move(press_path, lambda: arm.pad_state().normal_force_n > 5.0, speed_rad_s=0.05)
        hold_until = world.time_s + 0.25
        while world.time_s < hold_until:
            world.step(arm.control_steps)
            forces.append(arm.pad_state().normal_force_n)
        arm.guarded_move(home_q[None], lambda: False, speed_rad_s=0.2)
    return time.perf_counter() - start_wall


def measure(robot: str = "armar3", seconds: float = 10.0, time_step_s: float | None = None) -> SpeedFigures:
    """Real-time factors of :class:`SimWorld` + :class:`SimArm` pressing a box, DIRECT mode."""
    spec = load(robot)
    kinematics = ArmKinematics(spec)
    home = kinematics.forward_kinematics(spec.home_q)
    approach = home.z_axis
    # the box face lies 1 cm ahead of the pad, tilted 10 degrees from facing the pad
    tilt_axis = np.cross(approach, [0.0, 0.0, 1.0])
    tilt_axis /= np.linalg.norm(tilt_axis)
    angle = math.radians(10.0)
    normal = -(approach * math.cos(angle) + np.cross(tilt_axis, approach) * math.sin(angle))
    x = np.cross([0.0, 1.0, 0.0], normal)
    x /= np.linalg.norm(x)
    frame = np.stack([x, np.cross(normal, x), normal], axis=1)
    points = home.position_m + np.linspace(0.0, 0.03, 7)[:, None] * approach
    ik = solve_pad_ik(kinematics, points, np.tile(approach, (len(points), 1)), q_seed=spec.home_q)
    if not ik.success.all():
        raise RuntimeError(f"benchmark press path unreachable for {robot}")
    options = {} if time_step_s is None else {"time_step_s": time_step_s}
    factors, forces = [], []
    with tempfile.TemporaryDirectory() as tmp:
        box = _box_urdf(Path(tmp))
        for with_listener in (True, False):
            with SimWorld(table=None, **options) as world:
                arm = SimArm(world, spec)
                world.add_object(box, home.position_m + 0.01 * approach - BOX_SIZE_M[2] / 2 * normal,
                                 matrix_to_quat(frame))
                if with_listener:
                    world.add_step_listener(lambda t: arm.pad_state())
                wall = _press_cycles(world, arm, ik.q_rad, spec.home_q, seconds, forces)
                factors.append(world.time_s / wall)
                dt = world.time_step_s
    pressing = [f for f in forces if f > 0.0]
    return SpeedFigures(robot, dt, factors[0], factors[1], seconds, float(np.mean(pressing)) if pressing else 0.0)
