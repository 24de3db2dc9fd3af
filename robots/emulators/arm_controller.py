"""An emulated arm controller that executes the line protocol of ``docs/ROBOT_PROTOCOL.md``.

Joint dynamics: each joint follows its target as a first-order lag, ``dq/dt = (target - q) / tau``,
integrated exactly between events. Targets outside the joint limits are refused (``ERR``,
OUT_OF_LIMITS). Encoders report the true angles quantised to ``encoder_resolution_rad``.
Watchdog: while TRACKING, if no valid frame arrives for ``watchdog_s``, the target becomes the
position at that instant and the status WATCHDOG_HOLD, which refuses SETQ until a STOP
acknowledges it. A latched fault (:meth:`latch_fault`)
stops the arm the same way and refuses SETQ until a CLEAR succeeds.

Time comes from ``clock`` (a :class:`sensor.emulators.FakeClock`'s ``monotonic`` in tests, the
host's monotonic clock for a live demo); the state is brought up to date lazily, whenever the
controller is asked something.
"""
from __future__ import annotations

import math
import time
from typing import Callable

import numpy as np

from robots.hardware.protocol import (Command, ControllerStatus, ErrorCode, FrameError, RequestError,
                                      decode_frame, encode_ack, encode_encoder_reply, encode_error,
                                      encode_hello, is_fault, parse_request)

DEFAULT_ENCODER_RESOLUTION_RAD = 2.0 * math.pi / 2**17  # a 17-bit absolute encoder
LIMIT_SLACK_RAD = 1e-6  # the protocol's angle resolution


class EmulatedArmController:
    """A joint-position controller with first-order joints, limits, encoder quantisation and a watchdog.

    Parameters
    ----------
    lower_rad, upper_rad : (dof,) float
        Joint limits, radians.
    q_init_rad : (dof,) float or None
        Initial joint angles (default: mid-range).
    clock : callable
        Monotonic time, seconds.
    time_constant_s : float
        First-order lag of every joint, seconds.
    encoder_resolution_rad : float
        Encoder quantisation step, radians (0: none).
    watchdog_s : float
        Watchdog timeout while tracking, seconds.
    info : str
        Free text of the HELLO reply.

    Attributes
    ----------
    status : ControllerStatus
    target : (dof,) float
        Current position target, radians.
    fault_cause_present : bool
        While True, CLEAR is refused (FAULT_PERSISTS); :meth:`latch_fault` sets it, tests reset it.
    commands : collections.Counter-like dict
        Valid requests executed, by command name.
    watchdog_trips : int
    """

    def __init__(self, lower_rad, upper_rad, *, q_init_rad=None, clock: Callable[[], float] = time.monotonic,
                 time_constant_s: float = 0.03, encoder_resolution_rad: float = DEFAULT_ENCODER_RESOLUTION_RAD,
                 watchdog_s: float = 0.2, info: str = "armemu 1.0"):
        self.lower_rad = np.asarray(lower_rad, dtype=float)
        self.upper_rad = np.asarray(upper_rad, dtype=float)
        if self.lower_rad.ndim != 1 or self.lower_rad.shape != self.upper_rad.shape or len(self.lower_rad) == 0:
            raise ValueError(f"lower_rad and upper_rad must be (dof,) arrays of one shape, got "
                             f"{self.lower_rad.shape} and {self.upper_rad.shape}")
        if not np.all(self.lower_rad < self.upper_rad):
            raise ValueError("every lower joint limit must be below its upper limit")
        if not time_constant_s > 0.0:
            raise ValueError(f"time_constant_s must be > 0 s, got {time_constant_s}")
        if not encoder_resolution_rad >= 0.0:
            raise ValueError(f"encoder_resolution_rad must be >= 0, got {encoder_resolution_rad}")
        if not watchdog_s > 0.0:
            raise ValueError(f"watchdog_s must be > 0 s, got {watchdog_s}")
        q = 0.5 * (self.lower_rad + self.upper_rad) if q_init_rad is None else np.asarray(q_init_rad, dtype=float)
        if q.shape != self.lower_rad.shape or not self._within_limits(q):
            raise ValueError(f"q_init_rad must be {self.dof} angles within the joint limits, got {q}")
        self.clock = clock
        self.time_constant_s = float(time_constant_s)
        self.encoder_resolution_rad = float(encoder_resolution_rad)
        self.watchdog_s = float(watchdog_s)
        self.info = info
        self._q = q.copy()
        self.target = q.copy()
        self.status = ControllerStatus.IDLE
        self.fault_cause_present = False
        self.commands: dict[str, int] = {}
        self.watchdog_trips = 0
        self._t = clock()
        self._last_frame_t = self._t

    @classmethod
    def for_spec(cls, spec, **options) -> "EmulatedArmController":
        """A controller with the joint limits of a :class:`robots.spec.RobotSpec`'s URDF, starting at home."""
        from robots.urdf_check import check_spec_against_urdf
        tree = check_spec_against_urdf(spec)
        lower = [tree.joint(n).lower_rad for n in spec.joint_names]
        upper = [tree.joint(n).upper_rad for n in spec.joint_names]
        options.setdefault("q_init_rad", spec.home_q)
        return cls(lower, upper, **options)

    @property
    def dof(self) -> int:
        return len(self.lower_rad)

    # ---- what the emulated hardware is doing (for tests) -------------------------------------

    @property
    def true_q(self) -> np.ndarray:
        """True joint angles now, radians."""
        self.advance()
        return self._q.copy()

    @property
    def encoder_q(self) -> np.ndarray:
        """What the encoders report now, radians."""
        return self._quantised(self.true_q)

    @property
    def is_moving(self) -> bool:
        """True while some joint is more than one encoder step away from its target."""
        self.advance()
        step = max(self.encoder_resolution_rad, 1e-9)
        return bool(np.any(np.abs(self.target - self._q) > step))

    def latch_fault(self, status: ControllerStatus) -> None:
        """Latch a fault (drive fault, e-stop ...): hold position now, refuse SETQ until CLEAR."""
        status = ControllerStatus(status)
        if not is_fault(status):
            raise ValueError(f"{status.name} is not a fault status")
        self.advance()
        self.target = self._q.copy()
        self.status = status
        self.fault_cause_present = True

    # ---- protocol ----------------------------------------------------------------------------

    def handle_line(self, line: bytes) -> bytes | None:
        """Execute one request line; returns the reply frame, or None for a frame failing its checksum.

        Frames that fail the checksum are dropped silently: their sequence number cannot be trusted.
        """
        self.advance()
        try:
            fields = decode_frame(line)
        except FrameError:
            return None
        self._last_frame_t = self._t
        try:
            request = parse_request(fields)
        except RequestError as error:
            return encode_error(error.seq, error.code, self.status, str(error))
        except FrameError as error:
            return encode_error(0, ErrorCode.SYNTAX, self.status, str(error))
        self.commands[request.command.value] = self.commands.get(request.command.value, 0) + 1
        return self._execute(request)

    def _execute(self, request) -> bytes:
        seq, command = request.seq, request.command
        if command is Command.HELLO:
            return encode_hello(seq, self.dof, round(self.watchdog_s * 1e3), self.status, self.info)
        if command is Command.GETQ:
            t_ms = int(round(self._t * 1e3))
            return encode_encoder_reply(seq, t_ms, self.status, self._quantised(self._q))
        if command is Command.STOP:
            self.target = self._q.copy()
            if not is_fault(self.status):
                self.status = ControllerStatus.IDLE
            return encode_ack(seq, self.status)
        if command is Command.CLEAR:
            if is_fault(self.status):
                if self.fault_cause_present:
                    return encode_error(seq, ErrorCode.FAULT_PERSISTS, self.status,
                                        f"{self.status.name} cause still present")
                self.status = ControllerStatus.IDLE
            return encode_ack(seq, self.status)
        return self._set_target(seq, request.q)

    def _set_target(self, seq: int, q: np.ndarray) -> bytes:
        if is_fault(self.status):
            return encode_error(seq, ErrorCode.FAULTED, self.status, f"{self.status.name} latched; CLEAR first")
        if self.status == ControllerStatus.WATCHDOG_HOLD:
            return encode_error(seq, ErrorCode.WATCHDOG_TRIPPED, self.status,
                                "watchdog stop not acknowledged; STOP first")
        if len(q) != self.dof:
            return encode_error(seq, ErrorCode.DOF_MISMATCH, self.status, f"{len(q)} angles for {self.dof} joints")
        if not self._within_limits(q):
            bad = [i for i in range(self.dof)
                   if not self.lower_rad[i] - LIMIT_SLACK_RAD <= q[i] <= self.upper_rad[i] + LIMIT_SLACK_RAD]
            return encode_error(seq, ErrorCode.OUT_OF_LIMITS, self.status, f"joints {bad} outside limits")
        self.target = np.clip(q, self.lower_rad, self.upper_rad)
        self.status = ControllerStatus.TRACKING
        return encode_ack(seq, self.status)

    # ---- dynamics ----------------------------------------------------------------------------

    def advance(self) -> None:
        """Bring joints and watchdog up to ``clock()``."""
        now = self.clock()
        if now < self._t:
            raise ValueError(f"the controller clock went back from {self._t} s to {now} s")
        if self.status == ControllerStatus.TRACKING:
            trip = self._last_frame_t + self.watchdog_s
            if now > trip:
                self._integrate(max(trip, self._t))
                self.target = self._q.copy()
                self.status = ControllerStatus.WATCHDOG_HOLD
                self.watchdog_trips += 1
        self._integrate(now)

    def _integrate(self, until: float) -> None:
        dt = until - self._t
        if dt > 0.0:
            self._q = self.target + (self._q - self.target) * math.exp(-dt / self.time_constant_s)
            self._t = until

    def _quantised(self, q: np.ndarray) -> np.ndarray:
        if self.encoder_resolution_rad == 0.0:
            return q.copy()
        return np.round(q / self.encoder_resolution_rad) * self.encoder_resolution_rad

    def _within_limits(self, q: np.ndarray) -> bool:
        return bool(np.all((self.lower_rad - LIMIT_SLACK_RAD <= q) & (q <= self.upper_rad + LIMIT_SLACK_RAD)))
