"""Faults the emulated buses and ports can inject, one transaction at a time."""
from __future__ import annotations

import enum
from collections import Counter
from dataclasses import dataclass


class Fault(enum.Enum):
    """What goes wrong with a transaction.

    I2C (:class:`~sensor.emulators.fake_smbus.FakeSMBus`): ``NACK`` (OSError EREMOTEIO),
    ``IO_ERROR`` (OSError EIO), ``BUS_TIMEOUT`` (TimeoutError ETIMEDOUT), ``DISCONNECT`` (this
    and every later transfer fails with ENXIO).

    UART (:class:`~sensor.emulators.bno055_serial.FakeBNO055Serial`): ``NO_REPLY`` (request
    swallowed), ``OVERRUN`` (``EE 07``), ``FAIL_STATUS`` (``EE 02`` READ_FAIL / ``EE 03``
    WRITE_FAIL), ``INVALID_ADDRESS`` (``EE 04``), ``TRUNCATED`` (reply cut short), ``GARBAGE``
    (noise bytes before the reply), ``DISCONNECT`` (the port raises from now on), ``SILENT``
    (the port returns nothing from now on).
    """

    NACK = "nack"
    IO_ERROR = "io_error"
    BUS_TIMEOUT = "bus_timeout"
    NO_REPLY = "no_reply"
    OVERRUN = "overrun"
    FAIL_STATUS = "fail_status"
    INVALID_ADDRESS = "invalid_address"
    TRUNCATED = "truncated"
    GARBAGE = "garbage"
    DISCONNECT = "disconnect"
    SILENT = "silent"

    @property
    def permanent(self) -> bool:
        return self in (Fault.DISCONNECT, Fault.SILENT)


@dataclass
class _Pending:
    fault: Fault
    remaining: int
    register: int | None


class FaultInjector:
    """A queue of faults to apply to coming transactions.

    ``inject(Fault.OVERRUN, times=2, register=0x20)`` makes the next two transactions at register
    0x20 fail that way. Permanent faults (DISCONNECT, SILENT) stay once triggered.

    Attributes
    ----------
    triggered : collections.Counter
        How many transactions each fault has hit.
    """

    def __init__(self):
        self._pending: list[_Pending] = []
        self.permanent: Fault | None = None
        self.triggered: Counter = Counter()

    def inject(self, fault: Fault, times: int = 1, register: int | None = None) -> None:
        if not isinstance(fault, Fault):
            raise TypeError(f"fault must be a Fault, got {fault!r}")
        if times < 1:
            raise ValueError(f"times must be >= 1, got {times}")
        self._pending.append(_Pending(fault, times, register))

    def clear(self) -> None:
        """Drop pending faults and heal a permanent one (the cable is plugged back in)."""
        self._pending.clear()
        self.permanent = None

    def take(self, register: int | None) -> Fault | None:
        """The fault for a transaction at ``register`` (None if it goes through)."""
        if self.permanent is not None:
            self.triggered[self.permanent] += 1
            return self.permanent
        for pending in self._pending:
            if pending.register is None or pending.register == register:
                pending.remaining -= 1
                if pending.remaining == 0:
                    self._pending.remove(pending)
                if pending.fault.permanent:
                    self.permanent = pending.fault
                self.triggered[pending.fault] += 1
                return pending.fault
        return None
