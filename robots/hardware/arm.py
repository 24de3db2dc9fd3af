"""HardwareArm: a :class:`robots.interface.Robot` on any :class:`JointInterface`; SerialArm on the line protocol.

Motions are streamed: every control tick (``control_rate_hz``, 100 Hz by default) the host reads
the encoders, calls the guarded move's ``stop()`` predicate, and sends the next point of the
path, interpolated in time so that the fastest joint moves at the requested speed (as
:class:`robots.sim_arm.SimArm` does). Every motion ends with STOP, so between motions the
controller holds position with its watchdog disarmed. Any error during a motion triggers a STOP
attempt before it propagates; hardware errors then say during which call they happened and
whether the STOP was confirmed.
"""
from __future__ import annotations

import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

from robots.hardware.errors import RobotHardwareError
from robots.hardware.joint_interface import JointInterface
from robots.hardware.serial_joints import LinkStats, SerialJointInterface
from robots.interface import GuardedMoveResult, MoveNotReachedError, Robot, checked_joint_positions
from robots.spec import RobotSpec
from robots.urdf_check import check_spec_against_urdf

REACHED_TOLERANCE_RAD = 2e-3
SETTLE_TIMEOUT_S = 1.0
CONTROL_RATE_HZ = 100.0


def _as_spec(spec: RobotSpec | str | Path) -> RobotSpec:
    if isinstance(spec, RobotSpec):
        return spec
    if isinstance(spec, (str, Path)):
        from robots.registry import load
        return load(spec)
    raise TypeError(f"spec must be a RobotSpec, a registered robot name or a spec .json path, got {spec!r}")


class HardwareArm(Robot):
    """A real arm behind the :class:`Robot` interface.

    Parameters
    ----------
    joints : JointInterface
        Encoders and joint targets (serial protocol, ROS, vendor SDK ...).
    spec : RobotSpec or str
        The robot (or its registered name); joint order, and joint limits from its URDF.
    control_rate_hz : float
        Streaming rate of joint targets and encoder polls.
    reached_tolerance_rad : float
        A motion has reached its end when every encoder is this close to it, radians.
    settle_timeout_s : float
        How long after the path's end a motion may take to reach it, seconds.
    clock, sleep : callable
        Host monotonic clock and sleep (injectable for tests).

    Attributes
    ----------
    overruns : int
        Control ticks that started late because the previous one (``stop()`` included) took
        longer than a tick.
    """

    def __init__(self, joints: JointInterface, spec: RobotSpec | str, *, control_rate_hz: float = CONTROL_RATE_HZ,
                 reached_tolerance_rad: float = REACHED_TOLERANCE_RAD, settle_timeout_s: float = SETTLE_TIMEOUT_S,
                 clock: Callable[[], float] = time.monotonic, sleep: Callable[[float], None] = time.sleep):
        if not isinstance(joints, JointInterface):
            raise TypeError(f"joints must implement robots.hardware.JointInterface, got {type(joints).__name__}")
        spec = _as_spec(spec)
        tree = check_spec_against_urdf(spec)
        if joints.dof != spec.dof:
            raise ValueError(f"{joints.device} has {joints.dof} joints, robot {spec.name!r} has {spec.dof}")
        if not control_rate_hz > 0.0:
            raise ValueError(f"control_rate_hz must be > 0, got {control_rate_hz}")
        if not reached_tolerance_rad > 0.0:
            raise ValueError(f"reached_tolerance_rad must be > 0, got {reached_tolerance_rad}")
        if not settle_timeout_s >= 0.0:
            raise ValueError(f"settle_timeout_s must be >= 0, got {settle_timeout_s}")
        self.joints = joints
        self.spec = spec
        self.lower_rad = np.array([tree.joint(n).lower_rad for n in spec.joint_names])
        self.upper_rad = np.array([tree.joint(n).upper_rad for n in spec.joint_names])
        self.control_period_s = 1.0 / float(control_rate_hz)
        self.reached_tolerance_rad = float(reached_tolerance_rad)
        self.settle_timeout_s = float(settle_timeout_s)
        self.clock = clock
        self.sleep = sleep
        self.overruns = 0

    # ---- lifetime ----------------------------------------------------------------------------

    def open(self) -> None:
        """Connect to the controller. Idempotent."""
        self.joints.open()

    def close(self) -> None:
        """Leave the arm holding and disconnect. Idempotent."""
        self.joints.close()

    def __enter__(self) -> "HardwareArm":
        self.open()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @property
    def device(self) -> str:
        return self.joints.device

    # ---- Robot interface ---------------------------------------------------------------------

    @property
    def dof(self) -> int:
        return self.spec.dof

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self.spec.joint_names

    def time_s(self) -> float:
        """Host monotonic time, seconds (the clock encoder readings are stamped with)."""
        return self.clock()

    def joint_positions(self) -> np.ndarray:
        """Encoder readings (dof,), radians."""
        return self._encoders()

    def move_joints(self, q, speed_rad_s: float = 1.0) -> None:
        """Move along a straight joint-space line to ``q`` ((dof,) radians) and return when reached.

        Raises
        ------
        MoveNotReachedError
            The encoders are not within ``reached_tolerance_rad`` of ``q`` ``settle_timeout_s``
            after the motion's planned end (blocked?). The arm holds where it stopped.
        RobotHardwareError
            From the controller; STOP has been tried.
        """
        target = self._checked_q(q, "q")
        result = self._follow(target[None], None, speed_rad_s, "move_joints")
        error = float(np.max(np.abs(result.q - target)))
        if error > self.reached_tolerance_rad:
            raise MoveNotReachedError(f"{self.device}: stopped {np.degrees(error):.2f} deg away from the target "
                                      f"(blocked, or too slow for settle_timeout_s = {self.settle_timeout_s} s?)")

    def guarded_move(self, path, stop: Callable[[], bool], speed_rad_s: float = 0.2) -> GuardedMoveResult:
        """Stream ``path`` ((k, dof) radians) from the current position, calling ``stop()`` each tick.

        When ``stop()`` returns True, STOP is sent and the arm holds; the result's ``q`` is read
        after the STOP. Errors (from the controller or from ``stop()`` itself) send STOP first.
        """
        path = np.asarray(path, dtype=float)
        if path.ndim != 2 or path.shape[1] != self.dof or len(path) == 0:
            raise ValueError(f"path must have shape (k, {self.dof}) with k >= 1, got {path.shape}")
        for i, waypoint in enumerate(path):
            self._checked_q(waypoint, f"path[{i}]")
        if not callable(stop):
            raise TypeError("stop must be a callable returning bool")
        return self._follow(path, stop, speed_rad_s, "guarded_move")

    def hold(self, duration_s: float, stop: Callable[[], bool] | None = None) -> GuardedMoveResult:
        """Command the current position for ``duration_s``, calling ``stop()`` each tick."""
        if not duration_s >= 0.0:
            raise ValueError(f"duration_s must be >= 0, got {duration_s}")
        try:
            q = self._within_limits(self._encoders())
            t0 = self.clock()
            while self.clock() - t0 < duration_s:
                if stop is not None and stop():
                    return GuardedMoveResult(stopped=True, q=self._encoders(), waypoint_index=0)
                self.joints.command(q)
                self.sleep(self.control_period_s)
                self._encoders()
            return GuardedMoveResult(stopped=False, q=self._encoders(), waypoint_index=0)
        except RobotHardwareError as error:
            raise error.during(f"during hold; {self._stop_after_error()}") from error
        except BaseException:
            self._stop_after_error()
            raise

    # ---- internals ---------------------------------------------------------------------------

    def _checked_q(self, q, name: str) -> np.ndarray:
        return checked_joint_positions(q, name, self.joint_names, self.lower_rad, self.upper_rad)

    def _follow(self, path: np.ndarray, stop: Callable[[], bool] | None, speed_rad_s: float,
                operation: str) -> GuardedMoveResult:
        if not speed_rad_s > 0.0:
            raise ValueError(f"speed_rad_s must be positive, got {speed_rad_s}")
        try:
            return self._stream(path, stop, float(speed_rad_s))
        except RobotHardwareError as error:
            raise error.during(f"during {operation}; {self._stop_after_error()}") from error
        except BaseException:
            self._stop_after_error()
            raise

    def _stream(self, path: np.ndarray, stop: Callable[[], bool] | None, speed_rad_s: float) -> GuardedMoveResult:
        start = self._encoders()
        t0 = self.clock()
        points = np.vstack([start[None], path])
        durations = np.max(np.abs(np.diff(points, axis=0)), axis=1) / speed_rad_s
        ends = np.cumsum(durations)
        total = float(ends[-1])
        next_tick = t0
        while True:
            q = self._encoders()
            t = self.clock() - t0
            segment = min(int(np.searchsorted(ends, t, side="right")), len(path) - 1)
            if stop is not None and stop():
                self.joints.stop()
                return GuardedMoveResult(stopped=True, q=self._encoders(), waypoint_index=segment)
            if t >= total:
                target = path[-1]
                reached = np.max(np.abs(q - target)) <= self.reached_tolerance_rad
                if reached or t >= total + self.settle_timeout_s:
                    self.joints.stop()
                    return GuardedMoveResult(stopped=False, q=q, waypoint_index=len(path) - 1)
            else:
                seg_start = ends[segment] - durations[segment]
                fraction = (t - seg_start) / durations[segment] if durations[segment] > 0 else 1.0
                target = points[segment] + fraction * (points[segment + 1] - points[segment])
            self.joints.command(self._within_limits(target))
            next_tick += self.control_period_s
            delay = next_tick - self.clock()
            if delay < 0.0:
                self.overruns += 1
                next_tick = self.clock()
            else:
                self.sleep(delay)

    def _within_limits(self, q: np.ndarray) -> np.ndarray:
        """``q`` clipped to the joint limits: an encoder reads up to a step past a limit, and a
        target interpolated from there would be refused by the controller."""
        return np.clip(q, self.lower_rad, self.upper_rad)

    def _encoders(self) -> np.ndarray:
        _, q = self.joints.read_encoders()  # adapters may return a plain (t_s, q) tuple
        q = np.asarray(q, dtype=float)
        if q.shape != (self.dof,):
            raise ValueError(f"{self.device}: read_encoders() returned {q.shape} angles, expected ({self.dof},)")
        return q

    def _stop_after_error(self) -> str:
        try:
            self.joints.stop()
        except RobotHardwareError as error:
            return f"STOP could not be confirmed ({error.detail})"
        return "STOP sent and acknowledged"


class SerialArm(HardwareArm):
    """A :class:`HardwareArm` on the controller line protocol of ``docs/ROBOT_PROTOCOL.md``.

    The constructor does no I/O: call :meth:`open` (or use ``with``), which opens the port when
    it is given by name and checks the controller (HELLO).

    Parameters
    ----------
    port : str or pyserial-like
        ``"/dev/ttyUSB0"``, a pyserial URL (``"armemu://armar3"`` is the emulator) or an open
        port object (see :class:`SerialJointInterface`).
    spec : RobotSpec or str
    baudrate, reply_timeout_s, attempts, name
        See :class:`SerialJointInterface`.
    control_rate_hz, reached_tolerance_rad, settle_timeout_s, clock, sleep
        See :class:`HardwareArm`.
    """

    def __init__(self, port: Any, spec: RobotSpec | str, *, baudrate: int = 1_000_000,
                 reply_timeout_s: float = 0.05, attempts: int = 4, name: str | None = None,
                 control_rate_hz: float = CONTROL_RATE_HZ, reached_tolerance_rad: float = REACHED_TOLERANCE_RAD,
                 settle_timeout_s: float = SETTLE_TIMEOUT_S, clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep):
        spec = _as_spec(spec)
        joints = SerialJointInterface(port, spec.dof, baudrate=baudrate, reply_timeout_s=reply_timeout_s,
                                      attempts=attempts, name=name, clock=clock)
        super().__init__(joints, spec, control_rate_hz=control_rate_hz, reached_tolerance_rad=reached_tolerance_rad,
                         settle_timeout_s=settle_timeout_s, clock=clock, sleep=sleep)

    @property
    def link_stats(self) -> LinkStats:
        """Requests, retries, timeouts, corrupt and stale frames since :meth:`open`."""
        return self.joints.stats

    def clear_fault(self) -> None:
        """Reset a latched controller fault whose cause has been removed (``CLEAR``)."""
        self.joints.clear_fault()
