"""SerialJointInterface: the host side of the arm controller's line protocol.

One request, one reply: the request is written, then lines are read until the reply with the
same sequence number arrives or ``reply_timeout_s`` passes. Every request is idempotent (GETQ
reads, SETQ sets an absolute target, STOP/CLEAR/HELLO may be repeated), so a request whose reply
was lost, corrupted or late is simply sent again, up to ``attempts`` times; late replies to
earlier requests are recognised by their sequence number and dropped.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from robots.hardware.errors import (RobotCommandError, RobotConnectionError, RobotFaultError, RobotHardwareError,
                                    RobotNotOpenError, RobotProtocolError, RobotWatchdogError)
from common.serial_urls import register_serial_url_package
from robots.hardware.joint_interface import EncoderReading, JointInterface
from robots.hardware.protocol import (MAX_FRAME_BYTES, SEQ_MODULO, AckReply, Command, ControllerStatus, EncoderReply,
                                      ErrorCode, ErrorReply, FrameError, HelloReply, decode_frame,
                                      encode_request, is_fault, parse_reply, status_name)

EMULATOR_SCHEME = "armemu://"


@dataclass
class LinkStats:
    """What the link has seen since :meth:`SerialJointInterface.open`.

    Attributes
    ----------
    requests : int
        Requests sent, retries included.
    retries : int
        Requests sent again after a missing or unusable reply.
    timeouts : int
        Attempts that ended without the reply.
    corrupt_frames : int
        Lines dropped for a bad checksum or malformed content (noise, truncation).
    stale_replies : int
        Valid replies to an earlier request (arrived late), dropped.
    """

    requests: int = 0
    retries: int = 0
    timeouts: int = 0
    corrupt_frames: int = 0
    stale_replies: int = 0


def _port_name(port: Any) -> str:
    if isinstance(port, str):
        return port
    for attribute in ("port", "name"):
        value = getattr(port, attribute, None)
        if isinstance(value, str) and value:
            return value
    return type(port).__name__


class SerialJointInterface(JointInterface):
    """The protocol of ``docs/ROBOT_PROTOCOL.md`` over a serial port.

    Parameters
    ----------
    port : str or pyserial-like
        A device path or pyserial URL (opened in :meth:`open` with ``serial.serial_for_url``,
        closed in :meth:`close`; ``armemu://<robot>`` is the emulator), or an already open
        port object with ``read(size)``, ``write(data)`` and a short read timeout (then the
        caller owns it).
    dof : int
        Joints the controller must report in its HELLO reply.
    baudrate : int
        Used when opening a port by name.
    reply_timeout_s : float
        How long one attempt waits for its reply, seconds.
    attempts : int
        Tries per request before giving up.
    name : str or None
        Device name in messages (default ``"arm on <port>"``).
    clock : callable
        Host monotonic clock, seconds.
    """

    def __init__(self, port: Any, dof: int, *, baudrate: int = 1_000_000, reply_timeout_s: float = 0.05,
                 attempts: int = 4, name: str | None = None, clock: Callable[[], float] = time.monotonic):
        if not isinstance(port, str) and not (callable(getattr(port, "read", None))
                                              and callable(getattr(port, "write", None))):
            raise TypeError(f"port must be a device name or a pyserial-like object with read() and write(), "
                            f"got {port!r}")
        if isinstance(port, str) and not port:
            raise ValueError("port name is empty")
        if int(dof) < 1:
            raise ValueError(f"dof must be >= 1, got {dof}")
        if not reply_timeout_s > 0.0:
            raise ValueError(f"reply_timeout_s must be > 0 s, got {reply_timeout_s}")
        if int(attempts) < 1:
            raise ValueError(f"attempts must be >= 1, got {attempts}")
        self._port_spec = port
        self._dof = int(dof)
        self.baudrate = int(baudrate)
        self.reply_timeout_s = float(reply_timeout_s)
        self.attempts = int(attempts)
        self.clock = clock
        self._device = name or f"arm on {_port_name(port)}"
        self.stats = LinkStats()
        self.hello: HelloReply | None = None
        self.last_status: ControllerStatus | int | None = None
        self.last_q: np.ndarray | None = None
        self._port: Any = None
        self._owns_port = False
        self._seq = 0
        self._rx = bytearray()

    # ---- JointInterface ----------------------------------------------------------------------

    @property
    def device(self) -> str:
        return self._device

    @property
    def dof(self) -> int:
        return self._dof

    @property
    def is_open(self) -> bool:
        return self._port is not None

    def open(self) -> None:
        """Open the port (when given by name), drop stale input and check the controller (HELLO).

        Raises
        ------
        RobotConnectionError
            No HELLO reply (controller off, wrong port or baud rate).
        RobotProtocolError
            The controller reports a different number of joints.
        """
        if self.is_open:
            return
        if not isinstance(self._port_spec, str) and getattr(self._port_spec, "timeout", 0.0) is None:
            raise ValueError(f"{self.device}: the port has no read timeout (timeout=None blocks for ever when the "
                             f"controller is silent); open it with e.g. timeout=0.01")
        self._port, self._owns_port = self._open_port(), isinstance(self._port_spec, str)
        self.stats = LinkStats()
        self._rx.clear()
        try:
            reset = getattr(self._port, "reset_input_buffer", None)
            if callable(reset):
                reset()
            hello = self._transact(Command.HELLO, HelloReply, "HELLO")
            if hello.dof != self._dof:
                raise RobotProtocolError(self.device, f"controller reports {hello.dof} joints, the robot spec has "
                                                      f"{self._dof} (wrong controller or spec?)")
        except BaseException:
            self._release_port()
            raise
        self.hello = hello
        self.last_status = hello.status

    def close(self) -> None:
        """Send STOP (best effort, so the arm is left holding) and release the port. Idempotent."""
        if not self.is_open:
            return
        try:
            self.stop()
        except RobotHardwareError:
            pass  # closing must not fail because the controller is gone; its watchdog holds the arm
        finally:
            self._release_port()

    def read_encoders(self) -> EncoderReading:
        """``GETQ``: joint positions (radians) stamped with the host time mid-way through the exchange.

        Raises
        ------
        RobotFaultError
            The controller reports a latched fault (the positions are still in ``last_q``).
        RobotWatchdogError
            The controller's watchdog has stopped a motion.
        """
        start = self.clock()
        reply = self._transact(Command.GETQ, EncoderReply, "encoder")
        t_s = 0.5 * (start + self.clock())
        if len(reply.q) != self._dof:
            raise RobotProtocolError(self.device, f"encoder reply holds {len(reply.q)} angles, expected {self._dof}")
        self.last_q = reply.q
        self._check_status(reply.status)
        return EncoderReading(t_s, reply.q)

    def command(self, q: np.ndarray) -> None:
        """``SETQ``: new position target ((dof,) radians)."""
        q = np.asarray(q, dtype=float)
        if q.shape != (self._dof,) or not np.all(np.isfinite(q)):
            raise ValueError(f"{self.device}: target must be {self._dof} finite angles (rad), got shape {q.shape}")
        reply = self._transact(Command.SETQ, AckReply, "SETQ", q)
        self._check_status(reply.status)

    def stop(self) -> None:
        """``STOP``: hold the current position (also disarms the controller's watchdog)."""
        self._transact(Command.STOP, AckReply, "STOP")

    def clear_fault(self) -> None:
        """``CLEAR``: reset a latched fault whose cause has gone.

        Raises
        ------
        RobotCommandError
            The fault's cause is still present (code FAULT_PERSISTS).
        """
        self._transact(Command.CLEAR, AckReply, "CLEAR")

    # ---- internals ---------------------------------------------------------------------------

    def _open_port(self) -> Any:
        if not isinstance(self._port_spec, str):
            return self._port_spec
        try:
            import serial
        except ImportError as error:
            raise ImportError(f"{self.device}: opening a port by name needs pyserial: pip install pyserial "
                              f"(or the project's [hardware] extra)") from error
        if self._port_spec.startswith(EMULATOR_SCHEME):
            # by name: pyserial imports the emulator's handler only when such a URL is opened
            register_serial_url_package("robots.emulators", f"the {EMULATOR_SCHEME} URL")
        try:
            return serial.serial_for_url(self._port_spec, baudrate=self.baudrate,
                                         timeout=min(0.01, self.reply_timeout_s), write_timeout=self.reply_timeout_s)
        except (OSError, ValueError) as error:
            raise RobotConnectionError(self.device, f"cannot open the port: {error}") from error

    def _release_port(self) -> None:
        port, self._port = self._port, None
        if port is not None and self._owns_port:
            try:
                port.close()
            except OSError:
                pass

    def _check_status(self, status: ControllerStatus | int) -> None:
        self.last_status = status
        if is_fault(status):
            raise RobotFaultError(self.device, f"controller fault {status_name(status)}; the arm has stopped "
                                               f"(clear the cause, then clear_fault())", int(status))
        if status == ControllerStatus.WATCHDOG_HOLD:
            raise RobotWatchdogError(self.device, "the controller's watchdog stopped the arm: no command within "
                                                  f"{self._watchdog_text()} (host loop stalled?)")

    def _watchdog_text(self) -> str:
        return f"{self.hello.watchdog_ms} ms" if self.hello is not None else "its watchdog time"

    def _transact(self, command: Command, expected: type, what: str, q: np.ndarray | None = None):
        if self._port is None:
            raise RobotNotOpenError(self.device, "not open; call open() or use it as a context manager")
        started = self.clock()
        corrupt_before = self.stats.corrupt_frames
        for attempt in range(self.attempts):
            if attempt:
                self.stats.retries += 1
            self._seq = (self._seq + 1) % SEQ_MODULO
            self._write(encode_request(command, self._seq, q))
            reply = self._await_reply(self._seq)
            if reply is None:
                self.stats.timeouts += 1
                continue
            if isinstance(reply, ErrorReply):
                raise self._refusal(command, reply)
            if not isinstance(reply, expected):
                raise RobotProtocolError(self.device, f"{command.value} answered by {type(reply).__name__}")
            return reply
        elapsed = self.clock() - started
        tries = f"{self.attempts} attempt{'s' if self.attempts > 1 else ''}"
        if self.stats.corrupt_frames > corrupt_before:
            raise RobotProtocolError(self.device, f"no valid {what} reply for {elapsed:.2f} s ({tries}); "
                                                  f"{self.stats.corrupt_frames - corrupt_before} corrupted frames "
                                                  f"received (baud rate, wiring or noise?)")
        raise RobotConnectionError(self.device, f"no {what} reply for {elapsed:.2f} s ({tries})")

    def _refusal(self, command: Command, reply: ErrorReply) -> Exception:
        code = reply.code
        name = code.name if isinstance(code, ErrorCode) else f"error {code}"
        self.last_status = reply.status
        if code == ErrorCode.FAULTED:
            return RobotFaultError(self.device, f"{command.value} refused: controller fault "
                                                f"{status_name(reply.status)} ({reply.text})", int(reply.status))
        if code == ErrorCode.WATCHDOG_TRIPPED:
            return RobotWatchdogError(self.device, "the controller's watchdog stopped the arm: no command within "
                                                   f"{self._watchdog_text()} (host loop stalled?)")
        return RobotCommandError(self.device, f"{command.value} refused with {name}: {reply.text}", int(code))

    def _write(self, frame: bytes) -> None:
        self.stats.requests += 1
        try:
            self._port.write(frame)
        except OSError as error:  # pyserial's SerialException is an OSError
            raise RobotConnectionError(self.device, f"port failed while writing: {error}") from error

    def _await_reply(self, seq: int):
        deadline = self.clock() + self.reply_timeout_s
        while True:
            while (newline := self._rx.find(b"\n")) >= 0:
                line = bytes(self._rx[:newline])
                del self._rx[:newline + 1]
                reply = self._parse(line)
                if reply is None:
                    continue
                if reply.seq != seq:
                    self.stats.stale_replies += 1
                    continue
                return reply
            if len(self._rx) > MAX_FRAME_BYTES:  # no newline in sight: noise, not a frame
                self.stats.corrupt_frames += 1
                del self._rx[:-MAX_FRAME_BYTES]
            if self.clock() >= deadline:
                return None
            self._rx += self._read()

    def _read(self) -> bytes:
        try:
            waiting = getattr(self._port, "in_waiting", 0)
            return self._port.read(max(1, int(waiting)))
        except OSError as error:
            raise RobotConnectionError(self.device, f"port failed while reading: {error}") from error

    def _parse(self, line: bytes):
        if not line.strip():
            return None
        try:
            return parse_reply(decode_frame(line))
        except FrameError:
            self.stats.corrupt_frames += 1
            return None
