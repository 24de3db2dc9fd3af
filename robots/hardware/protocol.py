"""The arm controller's serial line protocol: frames, requests, replies, status and error codes.

Specified in ``docs/ROBOT_PROTOCOL.md``. In short, every frame is one ASCII line::

    $<body>*<CS>\\r\\n          CS: two hex digits, XOR of the bytes between '$' and '*'

Requests carry a sequence number that the reply echoes, so a late reply is never taken for the
answer to a newer request::

    $GETQ,<seq>*CS               -> $Q,<seq>,<t_ms>,<status>,<q1>,...,<qn>*CS
    $SETQ,<seq>,<q1>,...,<qn>*CS -> $OK,<seq>,<status>*CS  or  $ERR,<seq>,<code>,<status>,<text>*CS
    $STOP,<seq>*CS               -> $OK,<seq>,<status>*CS
    $CLEAR,<seq>*CS              -> $OK,<seq>,<status>*CS  or  $ERR,...
    $HELLO,<seq>*CS              -> $HI,<seq>,<dof>,<watchdog_ms>,<status>,<info>*CS

Joint angles are radians with six decimals. This module is pure: encoding and parsing only,
shared by the host (:mod:`robots.hardware.serial_joints`) and the emulator
(:mod:`robots.emulators.arm_controller`).
"""
from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

from common.sentences import SentenceError, checksum, frame, unframe  # noqa: F401 (checksum re-exported)

SEQ_MODULO = 65536
MAX_FRAME_BYTES = 512
ANGLE_DECIMALS = 6


class Command(str, enum.Enum):
    """Request names, host to controller."""

    HELLO = "HELLO"
    GETQ = "GETQ"
    SETQ = "SETQ"
    STOP = "STOP"
    CLEAR = "CLEAR"


class ControllerStatus(enum.IntEnum):
    """What the controller is doing; reported in every ``Q``, ``OK`` and ``HI`` reply.

    Codes >= 16 are latched faults: the controller has stopped the arm, refuses ``SETQ`` and
    stays faulted until a ``CLEAR`` succeeds.
    """

    IDLE = 0            # holding position, watchdog disarmed (after power-up, STOP or CLEAR)
    TRACKING = 1        # following SETQ targets, watchdog armed
    WATCHDOG_HOLD = 2   # no frame within the watchdog time while tracking: holding until STOP
    DRIVE_FAULT = 16    # amplifier / motor fault
    ENCODER_FAULT = 17  # encoder signal lost or implausible
    EMERGENCY_STOP = 18  # the e-stop circuit is open
    LIMIT_SWITCH = 19   # a hardware limit switch was hit


class ErrorCode(enum.IntEnum):
    """Why the controller refused a request (``ERR`` reply)."""

    SYNTAX = 1           # wrong field count or a field that is not a number
    UNKNOWN_COMMAND = 2  # request name not in Command
    DOF_MISMATCH = 3     # SETQ with a number of angles other than the arm's dof
    OUT_OF_LIMITS = 4    # SETQ target outside the controller's joint limits (target unchanged)
    FAULTED = 5          # SETQ while a fault is latched; send CLEAR first
    FAULT_PERSISTS = 6   # CLEAR refused: the fault's cause is still present
    WATCHDOG_TRIPPED = 7  # SETQ after a watchdog stop; send STOP to acknowledge it first


class FrameError(ValueError):
    """A line that is not a valid frame; ``kind`` is ``"checksum"`` or ``"malformed"``."""

    def __init__(self, kind: str, message: str):
        super().__init__(message)
        self.kind = kind


def encode_frame(fields: list[str]) -> bytes:
    """``$<fields joined by ','>*<CS>\\r\\n``."""
    return frame(",".join(fields))


def decode_frame(line: bytes) -> list[str]:
    """The comma-separated fields of one line (newline optional); raises :class:`FrameError`.

    Noise before the frame on the same line is ignored: parsing starts at the last ``$``.
    """
    try:
        return unframe(line).split(",")
    except SentenceError as error:
        raise FrameError(error.kind, str(error)) from None


def format_angles(q: np.ndarray) -> list[str]:
    return [f"{value:.{ANGLE_DECIMALS}f}" for value in q]


def _int(text: str, what: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise FrameError("malformed", f"{what} {text!r} is not an integer") from None


def _angles(fields: list[str]) -> np.ndarray:
    try:
        values = np.array([float(v) for v in fields])
    except ValueError:
        raise FrameError("malformed", f"joint angle fields {fields} are not all numbers") from None
    if not np.all(np.isfinite(values)):
        raise FrameError("malformed", "non-finite joint angle")
    return values


def _status(text: str) -> ControllerStatus | int:
    code = _int(text, "status")
    try:
        return ControllerStatus(code)
    except ValueError:
        return code  # an unknown code is kept: the host reports it instead of guessing


# ---- requests (host -> controller) -------------------------------------------------------------

@dataclass(frozen=True)
class Request:
    """A parsed request.

    Attributes
    ----------
    command : Command
    seq : int
    q : (n,) float or None
        SETQ target, radians.
    """

    command: Command
    seq: int
    q: np.ndarray | None = None


def encode_request(command: Command, seq: int, q: np.ndarray | None = None) -> bytes:
    fields = [Command(command).value, str(seq % SEQ_MODULO)]
    if q is not None:
        fields += format_angles(np.asarray(q, dtype=float))
    return encode_frame(fields)


class RequestError(ValueError):
    """A request frame that checks out but cannot be executed; the controller answers ERR."""

    def __init__(self, seq: int, code: ErrorCode, message: str):
        super().__init__(message)
        self.seq = seq
        self.code = code


def parse_request(fields: list[str]) -> Request:
    """Request from the fields of a valid frame; raises :class:`RequestError` (answered by ERR)."""
    seq = _int(fields[1], "sequence number") if len(fields) > 1 else 0
    try:
        command = Command(fields[0])
    except ValueError:
        raise RequestError(seq, ErrorCode.UNKNOWN_COMMAND, f"unknown command {fields[0]!r}") from None
    if len(fields) < 2:
        raise RequestError(0, ErrorCode.SYNTAX, f"{command.value} needs a sequence number")
    if command is Command.SETQ:
        try:
            return Request(command, seq, _angles(fields[2:]))
        except FrameError as error:
            raise RequestError(seq, ErrorCode.SYNTAX, str(error)) from None
    if len(fields) != 2:
        raise RequestError(seq, ErrorCode.SYNTAX, f"{command.value} takes only a sequence number")
    return Request(command, seq)


# ---- replies (controller -> host) --------------------------------------------------------------

@dataclass(frozen=True)
class EncoderReply:
    """``Q``: encoder positions.

    Attributes
    ----------
    seq : int
    t_device_ms : int
        Controller clock when the encoders were latched, ms, wraps at 2**32.
    status : ControllerStatus or int
    q : (n,) float
        Encoder positions, radians.
    """

    seq: int
    t_device_ms: int
    status: ControllerStatus | int
    q: np.ndarray


@dataclass(frozen=True)
class AckReply:
    """``OK``: request executed."""

    seq: int
    status: ControllerStatus | int


@dataclass(frozen=True)
class ErrorReply:
    """``ERR``: request refused, nothing changed."""

    seq: int
    code: ErrorCode | int
    status: ControllerStatus | int
    text: str


@dataclass(frozen=True)
class HelloReply:
    """``HI``: the controller introduces itself.

    Attributes
    ----------
    dof : int
    watchdog_ms : int
        The controller's watchdog timeout, ms.
    status : ControllerStatus or int
    info : str
        Firmware name and version (free text).
    """

    seq: int
    dof: int
    watchdog_ms: int
    status: ControllerStatus | int
    info: str


Reply = EncoderReply | AckReply | ErrorReply | HelloReply


def encode_encoder_reply(seq: int, t_device_ms: int, status: int, q: np.ndarray) -> bytes:
    return encode_frame(["Q", str(seq), str(t_device_ms % (1 << 32)), str(int(status)), *format_angles(q)])


def encode_ack(seq: int, status: int) -> bytes:
    return encode_frame(["OK", str(seq), str(int(status))])


def encode_error(seq: int, code: ErrorCode, status: int, text: str) -> bytes:
    clean = text.replace(",", ";").replace("*", " ").replace("$", " ")
    return encode_frame(["ERR", str(seq), str(int(code)), str(int(status)), clean])


def encode_hello(seq: int, dof: int, watchdog_ms: int, status: int, info: str) -> bytes:
    clean = info.replace(",", ";").replace("*", " ").replace("$", " ")
    return encode_frame(["HI", str(seq), str(dof), str(watchdog_ms), str(int(status)), clean])


def parse_reply(fields: list[str]) -> Reply:
    """Reply from the fields of a valid frame; raises :class:`FrameError` when malformed."""
    kind, rest = fields[0], fields[1:]
    if kind == "Q":
        if len(rest) < 4:
            raise FrameError("malformed", f"Q needs seq, t_ms, status and >= 1 angle, got {len(rest)} fields")
        t_ms = _int(rest[1], "t_ms")
        if not 0 <= t_ms < 1 << 32:
            raise FrameError("malformed", f"t_ms {t_ms} outside 0..2^32-1")
        return EncoderReply(_int(rest[0], "seq"), t_ms, _status(rest[2]), _angles(rest[3:]))
    if kind == "OK":
        if len(rest) != 2:
            raise FrameError("malformed", f"OK needs seq and status, got {len(rest)} fields")
        return AckReply(_int(rest[0], "seq"), _status(rest[1]))
    if kind == "ERR":
        if len(rest) != 4:
            raise FrameError("malformed", f"ERR needs seq, code, status and text, got {len(rest)} fields")
        code = _int(rest[1], "error code")
        try:
            code = ErrorCode(code)
        except ValueError:
            pass
        return ErrorReply(_int(rest[0], "seq"), code, _status(rest[2]), rest[3])
    if kind == "HI":
        if len(rest) != 5:
            raise FrameError("malformed", f"HI needs seq, dof, watchdog_ms, status and info, got {len(rest)} fields")
        dof, watchdog = _int(rest[1], "dof"), _int(rest[2], "watchdog_ms")
        if dof < 1 or watchdog < 0:
            raise FrameError("malformed", f"HI with dof {dof}, watchdog_ms {watchdog}")
        return HelloReply(_int(rest[0], "seq"), dof, watchdog, _status(rest[3]), rest[4])
    raise FrameError("malformed", f"unknown reply type {kind!r}")


def status_name(status: ControllerStatus | int) -> str:
    """``"DRIVE_FAULT (16)"``; unknown codes as ``"unknown status 99"``."""
    if isinstance(status, ControllerStatus):
        return f"{status.name} ({status.value})"
    return f"unknown status {status}"


def is_fault(status: ControllerStatus | int) -> bool:
    """True for latched faults, including codes this host does not know (>= 16)."""
    return int(status) >= 16
