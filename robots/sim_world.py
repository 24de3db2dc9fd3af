"""SimWorld: one PyBullet client with gravity, a ground plane, a table and static objects.

Each instance owns its own physics client (DIRECT by default, GUI on request); close it
explicitly or use it as a context manager. Callbacks run around every physics step:

* pre-step hooks (``add_pre_step_hook``) apply forces for the coming step (the fingertip spring);
* step listeners (``add_step_listener``) observe the state after it (simulated sensors sample the
  pad at their own rates from here). Both receive the simulation time in seconds.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from common.rotations import as_unit_quat_wxyz, wxyz_to_xyzw

DEFAULT_TIME_STEP_S = 1.0 / 480.0


def import_pybullet():
    """The pybullet module, with a helpful error when it is missing."""
    try:
        import pybullet
    except ImportError as err:
        raise ImportError("SimWorld needs pybullet: pip install pybullet") from err
    return pybullet


@dataclass(frozen=True)
class TableSpec:
    """A static box table: top face ``height_m`` above the floor, centred at ``center_xy_m``."""

    center_xy_m: tuple[float, float] = (0.45, -0.30)
    size_xy_m: tuple[float, float] = (0.6, 0.8)
    height_m: float = 0.75
    thickness_m: float = 0.04
    lateral_friction: float = 0.6

    def __post_init__(self) -> None:
        if min(self.size_xy_m) <= 0 or self.thickness_m <= 0 or self.height_m < self.thickness_m:
            raise ValueError(f"table dimensions must be positive and height >= thickness, got {self}")

    def box_m(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """The table as an axis-aligned box, world frame, metres: (centre (3,), half extent (3,)),
        from its top face down to the floor (a free move must not pass under it either)."""
        half = (self.size_xy_m[0] / 2.0, self.size_xy_m[1] / 2.0, self.height_m / 2.0)
        return (float(self.center_xy_m[0]), float(self.center_xy_m[1]), self.height_m / 2.0), half


@dataclass(frozen=True)
class ObjectHandle:
    """A static object placed in a :class:`SimWorld` (plain data; the world keeps the sim id).

    Attributes
    ----------
    key : int
        Identifies the object within its world.
    name : str
    urdf_path : Path
    position_m : (3,) float, world frame, metres
    quat_wxyz : (4,) float, world frame
    """

    key: int
    name: str
    urdf_path: Path
    position_m: np.ndarray = field(repr=False)
    quat_wxyz: np.ndarray = field(repr=False)


class SimWorld:
    """A PyBullet world; see the module docstring.

    Parameters
    ----------
    gui : bool
        Open the PyBullet GUI instead of the headless DIRECT server.
    time_step_s : float
        Physics step; 1/480 s keeps the default fingertip spring stable.
    gravity_mps2 : (3,) float
    ground : bool
        Add an infinite ground plane at z = 0.
    table : TableSpec or None
        The table to add, or None for none.
    solver_iterations : int
        PyBullet constraint solver iterations per step.
    """

    def __init__(
        self,
        gui: bool = False,
        time_step_s: float = DEFAULT_TIME_STEP_S,
        gravity_mps2=(0.0, 0.0, -9.81),
        ground: bool = True,
        table: TableSpec | None = TableSpec(),
        solver_iterations: int = 50,
    ):
        if not 0.0 < time_step_s <= 0.01:
            raise ValueError(f"time_step_s must be in (0, 0.01] s, got {time_step_s}")
        gravity = np.asarray(gravity_mps2, dtype=float)
        if gravity.shape != (3,) or not np.all(np.isfinite(gravity)):
            raise ValueError(f"gravity_mps2 must be 3 finite numbers, got {gravity_mps2!r}")
        pb = import_pybullet()
        self._pb = pb
        self.client = pb.connect(pb.GUI if gui else pb.DIRECT)
        if self.client < 0:
            mode = "GUI" if gui else "DIRECT"
            raise RuntimeError(f"cannot connect to a PyBullet {mode} server (no display for GUI?)")
        self._closed = False
        self.time_step_s = float(time_step_s)
        self._steps = 0
        self._pre_step: list[Callable[[float], None]] = []
        self._listeners: list[Callable[[float], None]] = []
        self._objects: dict[int, tuple[ObjectHandle, int]] = {}
        self._named_bodies: dict[int, str] = {}
        pb.setTimeStep(self.time_step_s, physicsClientId=self.client)
        pb.setGravity(*gravity, physicsClientId=self.client)
        pb.setPhysicsEngineParameter(numSolverIterations=solver_iterations, physicsClientId=self.client)
        if ground:
            plane = pb.createCollisionShape(pb.GEOM_PLANE, physicsClientId=self.client)
            self._named_bodies[pb.createMultiBody(0.0, plane, physicsClientId=self.client)] = "ground"
        self.table = table
        if table is not None:
            self._add_table(table)

    # ---- lifecycle ---------------------------------------------------------------------------

    def close(self) -> None:
        """Disconnect the physics client. Idempotent."""
        if not self._closed:
            self._pb.disconnect(physicsClientId=self.client)
            self._closed = True

    def __enter__(self) -> "SimWorld":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _check_open(self) -> None:
        if self._closed:
            raise RuntimeError("this SimWorld is closed")

    # ---- time --------------------------------------------------------------------------------

    @property
    def time_s(self) -> float:
        """Simulation time, seconds (steps taken x time step)."""
        return self._steps * self.time_step_s

    def step(self, n: int = 1) -> None:
        """Advance ``n`` physics steps, running the hooks and listeners around each."""
        self._check_open()
        pb, client = self._pb, self.client
        for _ in range(int(n)):
            t_next = (self._steps + 1) * self.time_step_s
            for hook in self._pre_step:
                hook(t_next)
            pb.stepSimulation(physicsClientId=client)
            self._steps += 1
            for listener in self._listeners:
                listener(t_next)

    def add_pre_step_hook(self, hook: Callable[[float], None]) -> Callable[[], None]:
        """Call ``hook(t_s)`` before every physics step; returns a function that removes it."""
        self._pre_step.append(hook)
        return lambda: self._pre_step.remove(hook) if hook in self._pre_step else None

    def add_step_listener(self, listener: Callable[[float], None]) -> Callable[[], None]:
        """Call ``listener(t_s)`` after every physics step; returns a function that removes it."""
        self._listeners.append(listener)
        return lambda: self._listeners.remove(listener) if listener in self._listeners else None

    # ---- bodies ------------------------------------------------------------------------------

    def load_urdf(self, urdf_path: Path, position_m, quat_wxyz, fixed_base: bool = True, scale: float = 1.0) -> int:
        """Load a URDF and return its PyBullet body id (for code inside robots/)."""
        self._check_open()
        path = Path(urdf_path)
        if not path.is_file():
            raise FileNotFoundError(f"URDF file not found: {path}")
        position = np.asarray(position_m, dtype=float)
        if position.shape != (3,) or not np.all(np.isfinite(position)):
            raise ValueError(f"position_m must be 3 finite numbers, got {position_m!r}")
        quat = as_unit_quat_wxyz(quat_wxyz, "quat_wxyz")
        if not scale > 0.0:
            raise ValueError(f"scale must be positive, got {scale}")
        pb = self._pb
        try:
            return pb.loadURDF(
                str(path),
                basePosition=position.tolist(),
                baseOrientation=wxyz_to_xyzw(quat).tolist(),
                useFixedBase=fixed_base,
                globalScaling=scale,
                flags=pb.URDF_USE_INERTIA_FROM_FILE,
                physicsClientId=self.client,
            )
        except pb.error as err:
            raise RuntimeError(f"PyBullet failed to load URDF {path}: {err}") from None

    def add_object(self, urdf_path: Path, position_m, quat_wxyz=(1.0, 0.0, 0.0, 0.0), scale: float = 1.0,
                   name: str | None = None) -> ObjectHandle:
        """Place a static object; ``position_m``/``quat_wxyz`` give its URDF root frame in world."""
        body = self.load_urdf(urdf_path, position_m, quat_wxyz, fixed_base=True, scale=scale)
        key = len(self._objects)
        handle = ObjectHandle(
            key=key,
            name=name or Path(urdf_path).stem,
            urdf_path=Path(urdf_path),
            position_m=np.asarray(position_m, dtype=float).copy(),
            quat_wxyz=as_unit_quat_wxyz(quat_wxyz),
        )
        self._objects[key] = (handle, body)
        self._named_bodies[body] = handle.name
        return handle

    def set_object_pose(self, handle: ObjectHandle, position_m, quat_wxyz) -> None:
        """Re-pose a static object (a turntable or positioner between touches)."""
        self._check_open()
        if handle.key not in self._objects:
            raise ValueError(f"object {handle.name!r} (key {handle.key}) is not in this world")
        position = np.asarray(position_m, dtype=float)
        if position.shape != (3,) or not np.all(np.isfinite(position)):
            raise ValueError(f"position_m must be 3 finite numbers, got {position_m!r}")
        _, body = self._objects[handle.key]
        self._pb.resetBasePositionAndOrientation(
            body, position.tolist(), wxyz_to_xyzw(as_unit_quat_wxyz(quat_wxyz)).tolist(),
            physicsClientId=self.client)

    def remove_object(self, handle: ObjectHandle) -> None:
        """Take an object out of the world."""
        self._check_open()
        if handle.key not in self._objects:
            raise ValueError(f"object {handle.name!r} (key {handle.key}) is not in this world")
        _, body = self._objects.pop(handle.key)
        self._named_bodies.pop(body, None)
        self._pb.removeBody(body, physicsClientId=self.client)

    def objects(self) -> list[ObjectHandle]:
        """The objects placed so far, in order."""
        return [handle for handle, _ in self._objects.values()]

    def body_name(self, body_id: int) -> str:
        """A readable name for a PyBullet body id: an object name, 'ground', 'table' or 'body N'."""
        return self._named_bodies.get(body_id, f"body {body_id}")

    def object_key(self, body_id: int) -> int | None:
        """The :class:`ObjectHandle` key of a body id, or None for ground, table or robots."""
        for key, (_, body) in self._objects.items():
            if body == body_id:
                return key
        return None

    def _add_table(self, table: TableSpec) -> None:
        pb = self._pb
        half = [table.size_xy_m[0] / 2.0, table.size_xy_m[1] / 2.0, table.thickness_m / 2.0]
        shape = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=half, physicsClientId=self.client)
        visual = pb.createVisualShape(pb.GEOM_BOX, halfExtents=half, rgbaColor=[0.6, 0.45, 0.3, 1.0],
                                      physicsClientId=self.client)
        centre = [table.center_xy_m[0], table.center_xy_m[1], table.height_m - table.thickness_m / 2.0]
        body = pb.createMultiBody(0.0, shape, visual, centre, physicsClientId=self.client)
        pb.changeDynamics(body, -1, lateralFriction=table.lateral_friction, physicsClientId=self.client)
        self._named_bodies[body] = "table"
