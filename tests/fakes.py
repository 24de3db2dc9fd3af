"""An in-memory rig for fast loop tests: a point pad pressing a virtual sphere, no simulator.

The "arm" has three joints that are the pad position itself (world frame, metres), so its
kinematics are the identity and the spring pivot is the pad. The pad is position controlled and
may sink into the sphere; the force is ``stiffness x depth``, the barometer reads the pad model's
pressure rise for that force, and the IMU reports the pad's +z axis pointing at the sphere centre
(the spring has aligned it). A contact measured with a matching :class:`PadCalibration` (a point
pad: a spring so soft that no torque moves the contact off the pad centre, :func:`point_pad`) is
therefore exactly on the sphere with the radial normal: tests can assert to 1e-9 m.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from types import SimpleNamespace

import numpy as np
from scipy.spatial.transform import Rotation

from explorer.planner import ApproachPlan, PlannerConfig, approach_line
from explorer.positioner import FixedStand
from explorer.strategies import ExplorationState, TouchStrategy
from explorer.touch import Touch
from robots.interface import GuardedMoveResult, MoveNotReachedError, Robot
from sensor.interface import TactileSensor
from sensor.pad_calibration import PAD_STIFFNESS_N_PER_M, PadCalibration
from sensor.reading import Reading
from sensor.sim.pad_response import PadResponse
from common.rotations import wxyz_from_rotation

TICK_S = 0.01
ATMOSPHERE_PA = 101325.0


def facing(direction: np.ndarray) -> np.ndarray:
    """(w, x, y, z) of the smallest rotation taking +z onto the unit ``direction``."""
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(z, direction)
    sine, cosine = float(np.linalg.norm(axis)), float(np.dot(z, direction))
    if sine < 1e-12:
        rotation = Rotation.identity() if cosine > 0 else Rotation.from_rotvec([np.pi, 0.0, 0.0])
    else:
        rotation = Rotation.from_rotvec(axis / sine * np.arctan2(sine, cosine))
    return wxyz_from_rotation(rotation)


@dataclass
class SphereWorld:
    """The shared state of the fake robot and sensor: time, pad position, readings not yet drained."""

    centre_m: np.ndarray
    radius_m: float
    pad: PadResponse = field(default_factory=PadResponse)
    stiffness_n_per_m: float = PAD_STIFFNESS_N_PER_M
    pad_m: np.ndarray | None = None
    t_s: float = 0.0
    buffer: list = field(default_factory=list)

    def __post_init__(self):
        self.centre_m = np.asarray(self.centre_m, float)
        if self.pad_m is None:
            self.pad_m = self.centre_m + np.array([0.0, -3.0 * self.radius_m, 0.0])

    def depth_m(self, p: np.ndarray) -> float:
        return max(self.radius_m - float(np.linalg.norm(p - self.centre_m)), 0.0)

    def reading(self) -> Reading:
        force = self.stiffness_n_per_m * self.depth_m(self.pad_m)
        inward = (self.centre_m - self.pad_m) / np.linalg.norm(self.centre_m - self.pad_m)
        return Reading(self.t_s, ATMOSPHERE_PA + self.pad.pressure_rise_pa(force), facing(inward),
                       np.zeros(3), np.array([0.0, 0.0, -9.81]))

    def tick(self) -> None:
        self.t_s = round(self.t_s + TICK_S, 9)
        self.buffer.append(self.reading())


class FakeRobot(Robot):
    """Three joints = the pad position (world, metres); ``speed_rad_s`` is metres per second."""

    def __init__(self, world: SphereWorld):
        self.world = world

    @property
    def dof(self) -> int:
        return 3

    def joint_positions(self) -> np.ndarray:
        return self.world.pad_m.copy()

    def time_s(self) -> float:
        return self.world.t_s

    def move_joints(self, q, speed_rad_s: float = 1.0) -> None:
        q = np.asarray(q, float)
        if self.world.depth_m(q) > 0.0:
            raise MoveNotReachedError(f"target {q} is inside the object")
        self.world.pad_m = q.copy()
        self.world.tick()

    def guarded_move(self, path, stop, speed_rad_s: float = 0.2) -> GuardedMoveResult:
        step = speed_rad_s * TICK_S
        for i, waypoint in enumerate(np.asarray(path, float)):
            while np.linalg.norm(waypoint - self.world.pad_m) > 1e-12:
                offset = waypoint - self.world.pad_m
                distance = float(np.linalg.norm(offset))
                self.world.pad_m = waypoint.copy() if distance <= step else self.world.pad_m + offset * step / distance
                self.world.tick()
                if stop():
                    return GuardedMoveResult(True, self.joint_positions(), i)
        return GuardedMoveResult(False, self.joint_positions(), len(path) - 1)

    def hold(self, duration_s: float, stop=None) -> GuardedMoveResult:
        end = self.world.t_s + duration_s - 1e-9
        while self.world.t_s < end:
            self.world.tick()
            if stop is not None and stop():
                return GuardedMoveResult(True, self.joint_positions(), 0)
        return GuardedMoveResult(False, self.joint_positions(), 0)


class FakeSensor(TactileSensor):
    """Readings of the :class:`SphereWorld`, one per tick."""

    def __init__(self, world: SphereWorld):
        self.world = world

    def read(self) -> Reading:
        return self.world.reading()

    def drain(self) -> list[Reading]:
        readings, self.world.buffer = self.world.buffer, []
        return readings


class FakeKinematics:
    """Identity kinematics: every link is at the pad, the pad face at the pivot."""

    spec = SimpleNamespace(pivot_link="pivot", tool_link="pad")
    pivot_to_pad_in_body = np.zeros(3)
    lower_rad = np.full(3, -np.inf)  # the pad position has no joint limits
    upper_rad = np.full(3, np.inf)

    def forward_kinematics(self, q, link=None):
        return SimpleNamespace(position_m=np.asarray(q, float).copy(), rotation=np.eye(3),
                               z_axis=np.array([0.0, 0.0, 1.0]))

    def pose_of_one(self, q, link=None):
        return np.asarray(q, float).copy(), np.eye(3)


class FakePlanner:
    """Plans every touch straight along its line at the stand's pose, except where ``unreachable(target_m)``."""

    def __init__(self, positioner, config: PlannerConfig = PlannerConfig(), unreachable=lambda target: False,
                 detour=None):
        self.positioner = positioner
        self.config = config
        self.unreachable = unreachable
        self.detour = detour  # callable (q_from, q_to) -> (k, 3) waypoints before q_to, or None: no clear path
        self.rest_q = positioner.centre_m + np.array([0.0, -0.2, 0.1])

    def transfer_path(self, q_from, q_to) -> np.ndarray | None:
        """Straight (``q_to`` alone) unless ``detour`` gives waypoints to pass first, or None (no
        clear path known)."""
        q_to = np.asarray(q_to, float)
        via = None if self.detour is None else self.detour(np.asarray(q_from, float), q_to)
        if via is None:
            return None if self.detour is not None else q_to[None]
        return q_to[None] if not len(via) else np.vstack([via, q_to[None]])

    def retreat_path(self, q, distance_m: float = 0.15, step_m: float = 0.01) -> np.ndarray:
        """The pad straight away from the stand centre (where the fake pad faces), ``step_m`` apart."""
        q = np.asarray(q, float)
        away = (q - self.positioner.centre_m) / np.linalg.norm(q - self.positioner.centre_m)
        steps = np.arange(1, int(round(distance_m / step_m)) + 1) * step_m
        return q + steps[:, None] * away

    def plan(self, touch: Touch, seed_q=None, touched_m=None) -> ApproachPlan | None:
        if self.unreachable(touch.target_m):
            return None
        pose = self.positioner.pose()
        target, approach = self.positioner.to_world(touch.target_m[None], touch.approach_dir[None], pose)
        points = approach_line(target[0], approach[0], self.config, touch.depth_m)
        return ApproachPlan(touch, pose, target[0], approach[0], points, points)


class ScriptedStrategy(TouchStrategy):
    """Proposes the given touches in order; a touch once accepted is not proposed again."""

    name = "scripted"

    def __init__(self, touches: list[Touch]):
        self.remaining = list(touches)

    def propose(self, state: ExplorationState, count: int) -> list[Touch]:
        return self.remaining[:count]

    def accepted(self, touch: Touch) -> None:
        self.remaining = [t for t in self.remaining if t is not touch]


def point_pad() -> PadCalibration:
    """The fake's pad: nominal force model and compliance, and a spring too soft to move the
    centre of pressure (``explorer.contact.pad_load``) off the pad centre."""
    return PadCalibration(spring_stiffness_nm_per_rad=1e-12)


def sphere_rig(radius_m: float = 0.04, centre_m=(0.0, 0.5, 1.0)):
    """(world, Rig) of a fake arm and sensor at a sphere held by a fixed stand at ``centre_m``."""
    from explorer.rig import Rig
    from explorer.touch import ObjectPrior

    world = SphereWorld(np.asarray(centre_m, float), radius_m)
    stand = FixedStand(world.centre_m)
    prior = ObjectPrior(np.zeros(3), np.full(3, 1.2 * radius_m))
    rig = Rig(FakeRobot(world), FakeSensor(world), FakeKinematics(), stand, prior, None,
              dict(robot="fake", sensor="fake", object="virtual sphere", backend="in memory"), point_pad())
    return world, rig


def session_recorded_without(session_dir, dest, *loop_settings):
    """A copy of a recorded session at ``dest`` whose metadata lacks these ``LoopConfig`` fields,
    as a session recorded before they existed; returns ``dest``."""
    import json
    import shutil

    shutil.copytree(session_dir, dest)
    metadata = json.loads((dest / "metadata.json").read_text())
    for name in loop_settings:
        del metadata["configuration"]["loop"][name]
    (dest / "metadata.json").write_text(json.dumps(metadata))
    return dest
