"""A pyserial-like port with an :class:`EmulatedArmController` behind it, and the faults it can inject."""
from __future__ import annotations

import enum
from collections import Counter
from dataclasses import dataclass

from robots.emulators.arm_controller import EmulatedArmController
from robots.hardware.protocol import ControllerStatus
from common.fake_port import FakeSerialPort

#: Noise put before a reply by ArmFault.GARBAGE: start and checksum markers followed by bytes that
#: cannot complete a frame, then a newline, to exercise resynchronisation.
DEFAULT_GARBAGE = b"\x00$Q,1*\xff\xfe$$OK*ZZ\r\n\x13"


class ArmPortDisconnectedError(OSError):
    """What the emulated port raises once disconnected (pyserial raises SerialException, an OSError)."""


class ArmFault(enum.Enum):
    """What goes wrong with one request.

    ``NO_REPLY``: the request is lost on the way (not executed, no reply). ``LOST_REPLY``: executed,
    reply lost. ``GARBAGE``: noise before the reply. ``CORRUPT``: a byte of the reply flipped
    (checksum fails). ``TRUNCATED``: the reply stops half-way. ``DELAYED``: the reply arrives only
    after the next request. ``DISCONNECT``: the port raises from now on (the controller hears
    nothing more, so its watchdog stops the arm). ``SILENT``: from now on requests are executed
    but no reply gets back (broken receive wire). ``DRIVE_FAULT``, ``EMERGENCY_STOP``: the
    controller latches that fault before handling the request.
    """

    NO_REPLY = "no_reply"
    LOST_REPLY = "lost_reply"
    GARBAGE = "garbage"
    CORRUPT = "corrupt"
    TRUNCATED = "truncated"
    DELAYED = "delayed"
    DISCONNECT = "disconnect"
    SILENT = "silent"
    DRIVE_FAULT = "drive_fault"
    EMERGENCY_STOP = "emergency_stop"

    @property
    def permanent(self) -> bool:
        return self in (ArmFault.DISCONNECT, ArmFault.SILENT)


@dataclass
class _Pending:
    fault: ArmFault
    remaining: int
    command: str | None
    skip: int


class ArmFaultInjector:
    """Faults for coming requests.

    ``inject(ArmFault.NO_REPLY, times=2, command="GETQ", after=5)`` lets five GETQ requests through,
    then loses the next two. Permanent faults (DISCONNECT, SILENT) stay once triggered.

    Attributes
    ----------
    triggered : collections.Counter
        Requests each fault has hit.
    """

    def __init__(self):
        self._pending: list[_Pending] = []
        self.permanent: ArmFault | None = None
        self.triggered: Counter = Counter()

    def inject(self, fault: ArmFault, times: int = 1, command: str | None = None, after: int = 0) -> None:
        if not isinstance(fault, ArmFault):
            raise TypeError(f"fault must be an ArmFault, got {fault!r}")
        if times < 1 or after < 0:
            raise ValueError(f"need times >= 1 and after >= 0, got times={times}, after={after}")
        self._pending.append(_Pending(fault, times, command, after))

    def clear(self) -> None:
        """Drop pending faults and heal a permanent one."""
        self._pending.clear()
        self.permanent = None

    def take(self, command: str | None) -> ArmFault | None:
        """The fault for a request named ``command`` (None when it goes through)."""
        if self.permanent is not None:
            self.triggered[self.permanent] += 1
            return self.permanent
        for pending in self._pending:
            if pending.command is not None and pending.command != command:
                continue
            if pending.skip:
                pending.skip -= 1
                continue
            pending.remaining -= 1
            if pending.remaining == 0:
                self._pending.remove(pending)
            if pending.fault.permanent:
                self.permanent = pending.fault
            self.triggered[pending.fault] += 1
            return pending.fault
        return None


def _command_of(line: bytes) -> str | None:
    start = line.rfind(b"$")
    if start < 0:
        return None
    name = line[start + 1:].split(b",", 1)[0].split(b"*", 1)[0]
    return name.decode("ascii", "replace")


class FakeArmSerial(FakeSerialPort):
    """pyserial-like port to an emulated controller.

    Each complete request line written is answered at once into the receive buffer (faults
    permitting). A read returns what is buffered, up to ``size`` bytes; when that is short, a real
    port would have blocked for ``timeout``, so the optional FakeClock is advanced by it.

    Parameters
    ----------
    controller : EmulatedArmController
    clock : sensor.emulators.FakeClock or None
    timeout : float
        Read timeout the port pretends to have, seconds.
    port : str
        Name reported as ``.port`` (pyserial's attribute).
    garbage : bytes
        Noise used by ArmFault.GARBAGE.

    Attributes
    ----------
    faults : ArmFaultInjector
    requests : list of bytes
        Every complete request line received (faulted ones included).
    """

    disconnect_error: type[Exception] = ArmPortDisconnectedError
    disconnect_fault = ArmFault.DISCONNECT

    def __init__(self, controller: EmulatedArmController, *, clock=None, timeout: float = 0.01,
                 port: str = "armemu://", garbage: bytes = DEFAULT_GARBAGE):
        super().__init__(clock, timeout)
        self.controller = controller
        self.port = port
        self.garbage = garbage
        self.faults = ArmFaultInjector()
        self.requests: list[bytes] = []
        self._from_host = bytearray()
        self._delayed: list[bytes] = []

    # ---- pyserial surface --------------------------------------------------------------------

    def write(self, data: bytes) -> int:
        self._check_connected()
        self._from_host += bytes(data)
        while (newline := self._from_host.find(b"\n")) >= 0:
            line = bytes(self._from_host[:newline + 1])
            del self._from_host[:newline + 1]
            self.requests.append(line)
            self._answer(line)
        return len(data)

    # ---- behaviour ---------------------------------------------------------------------------

    def _answer(self, line: bytes) -> None:
        fault = self.faults.take(_command_of(line))
        if fault is ArmFault.DISCONNECT:
            self._check_connected()
        late, self._delayed = b"".join(self._delayed), []
        self._to_host += late
        if fault is ArmFault.NO_REPLY:
            return
        if fault is ArmFault.DRIVE_FAULT:
            self.controller.latch_fault(ControllerStatus.DRIVE_FAULT)
        elif fault is ArmFault.EMERGENCY_STOP:
            self.controller.latch_fault(ControllerStatus.EMERGENCY_STOP)
        reply = self.controller.handle_line(line)
        if reply is None or fault in (ArmFault.LOST_REPLY, ArmFault.SILENT):
            return
        if fault is ArmFault.DELAYED:
            self._delayed.append(reply)
            return
        if fault is ArmFault.GARBAGE:
            reply = self.garbage + reply
        elif fault is ArmFault.CORRUPT:
            index = reply.index(b",") + 1  # flip a bit inside the body: the checksum no longer matches
            reply = reply[:index] + bytes([reply[index] ^ 0x01]) + reply[index + 1:]
        elif fault is ArmFault.TRUNCATED:
            reply = reply[:len(reply) // 2]
        self._to_host += reply
