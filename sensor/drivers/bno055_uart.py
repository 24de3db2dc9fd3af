"""BNO055 register access over its UART protocol (datasheet section 4.7), and :class:`BNO055UART`.

Framing (115200 8N1, at most 128 data bytes per transfer):

* write: host sends ``AA 00 reg len data...``; chip answers ``EE 01`` (WRITE_SUCCESS) or
  ``EE status``.
* read: host sends ``AA 01 reg len``; chip answers ``BB len data...`` or ``EE status``.

Transient statuses (READ_FAIL, WRITE_FAIL, WRONG_START_BYTE, BUS_OVER_RUN_ERROR,
RECEIVE_CHARACTER_TIMEOUT), silence and truncated replies are retried a bounded number of times
with a growing pause; bytes that cannot start a reply are skipped (resynchronisation). The port
is any object with pyserial's ``read(size)`` and ``write(data)``; this module never imports
pyserial.
"""
from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field
from typing import Any, Callable

from sensor.drivers.bno055 import BNO055
from sensor.drivers.bno055_registers import register_label
from sensor.drivers.errors import (BusError, DeviceDisconnectedError, DeviceTimeoutError,
                                   ProtocolError)

START = 0xAA
CMD_WRITE = 0x00
CMD_READ = 0x01
READ_REPLY = 0xBB
STATUS_REPLY = 0xEE
MAX_LENGTH = 128

STATUS_NAMES = {
    0x01: "WRITE_SUCCESS", 0x02: "READ_FAIL", 0x03: "WRITE_FAIL", 0x04: "REGMAP_INVALID_ADDRESS",
    0x05: "REGMAP_WRITE_DISABLED", 0x06: "WRONG_START_BYTE", 0x07: "BUS_OVER_RUN_ERROR",
    0x08: "MAX_LENGTH_ERROR", 0x09: "MIN_LENGTH_ERROR", 0x0A: "RECEIVE_CHARACTER_TIMEOUT",
}
WRITE_SUCCESS = 0x01
RETRYABLE_STATUSES = frozenset({0x02, 0x03, 0x06, 0x07, 0x0A})


@dataclass
class UartLinkStats:
    """Counters of what the link survived.

    Attributes
    ----------
    transactions : int
        Register reads and writes completed successfully.
    retries : int
        Extra attempts made.
    garbage_bytes : int
        Bytes skipped while looking for a reply header.
    timeouts : int
        Attempts that ended without a (complete) reply.
    statuses : dict[str, int]
        Error statuses received, by name.
    """

    transactions: int = 0
    retries: int = 0
    garbage_bytes: int = 0
    timeouts: int = 0
    statuses: dict[str, int] = field(default_factory=dict)


class _AttemptFailed(Exception):
    """One request/response attempt failed in a way that may clear on retry."""

    def __init__(self, reason: str, timed_out: bool):
        super().__init__(reason)
        self.timed_out = timed_out


class BNO055UartTransport:
    """Register read/write over the BNO055 UART protocol.

    Parameters
    ----------
    port : pyserial-like
        ``read(size) -> bytes`` (may return fewer bytes on timeout) and ``write(data)``.
        ``reset_input_buffer()`` is used when present.
    attempts : int
        Tries per register transfer (>= 1).
    reply_timeout_s : float
        Time allowed for one complete reply, seconds.
    retry_delay_s : float
        Pause before the first retry; doubles on each further retry.
    sleep, clock : callable
        Injectable ``sleep(seconds)`` and monotonic ``clock()``.
    """

    device = "BNO055 over UART"

    def __init__(self, port: Any, *, attempts: int = 4, reply_timeout_s: float = 0.05,
                 retry_delay_s: float = 0.002, sleep: Callable[[float], None] = time.sleep,
                 clock: Callable[[], float] = time.monotonic):
        if attempts < 1:
            raise ValueError(f"{self.device}: attempts must be >= 1, got {attempts}")
        if reply_timeout_s <= 0:
            raise ValueError(f"{self.device}: reply_timeout_s must be > 0, got {reply_timeout_s}")
        for method in ("read", "write"):
            if not callable(getattr(port, method, None)):
                raise TypeError(f"{self.device}: port object {port!r} lacks {method}()")
        if hasattr(port, "timeout") and port.timeout is None:
            raise ValueError(f"{self.device}: the port blocks forever on read (timeout=None); open it "
                             f"with a read timeout, e.g. serial.Serial(..., timeout=0.02)")
        self.port = port
        self.attempts = attempts
        self.reply_timeout_s = reply_timeout_s
        self.retry_delay_s = retry_delay_s
        self.sleep = sleep
        self.clock = clock
        self.stats = UartLinkStats()
        self._pushback = bytearray()
        self._register = 0  # register of the transaction in progress, for error messages

    def read(self, register: int, length: int) -> bytes:
        """Read ``length`` bytes starting at ``register``."""
        _check_request(self.device, register, length)
        request = bytes([START, CMD_READ, register, length])
        return self._transact(register, f"reading {length} bytes from", request,
                              lambda deadline: self._read_reply(length, deadline))

    def write(self, register: int, data: bytes | int) -> None:
        """Write one byte or a burst starting at ``register``."""
        payload = bytes([data]) if isinstance(data, int) else bytes(data)
        _check_request(self.device, register, len(payload))
        request = bytes([START, CMD_WRITE, register, len(payload)]) + payload
        self._transact(register, f"writing {len(payload)} bytes to", request, self._write_reply)

    # -- one transaction with retries -------------------------------------------------------

    def _transact(self, register: int, operation: str, request: bytes,
                  parse_reply: Callable[[float], Any]) -> Any:
        label = register_label(register)
        self._register = register
        failures = []
        for attempt in range(self.attempts):
            if attempt:
                self.stats.retries += 1
                self.sleep(self.retry_delay_s * (1 << (attempt - 1)))
            self._discard_stale_input(label)
            self._send(request, label)
            try:
                result = parse_reply(self.clock() + self.reply_timeout_s)
            except _AttemptFailed as failure:
                failures.append(failure)
                self.stats.timeouts += failure.timed_out
                continue
            self.stats.transactions += 1
            return result
        last = failures[-1]
        message = f"{operation} {label}: {last}; gave up after {self.attempts} attempts"
        if last.timed_out:
            raise DeviceTimeoutError(self.device, message, register)
        raise BusError(self.device, message, register)

    def _send(self, request: bytes, label: str) -> None:
        try:
            self.port.write(request)
        except OSError as exc:
            if _is_write_timeout(exc):
                raise DeviceTimeoutError(self.device, f"write timeout sending request for {label}",
                                         request[2]) from exc
            raise DeviceDisconnectedError(self.device, f"port failed while writing request for "
                                          f"{label}: {exc}", request[2]) from exc
        flush = getattr(self.port, "flush", None)
        if callable(flush):
            flush()

    def _discard_stale_input(self, label: str) -> None:
        self._pushback.clear()
        reset = getattr(self.port, "reset_input_buffer", None)
        if callable(reset):
            try:
                reset()
            except OSError as exc:
                raise DeviceDisconnectedError(self.device, f"port failed before {label}: {exc}",
                                              self._register) from exc

    # -- reply parsing ----------------------------------------------------------------------

    def _read_reply(self, length: int, deadline: float) -> bytes:
        garbage_budget = 64 + 2 * length
        while True:
            header = self._take(1, deadline)
            if header == bytes([READ_REPLY]):
                size = self._take(1, deadline)
                if not size:
                    raise _AttemptFailed("truncated reply: header without length", timed_out=True)
                if size[0] != length:
                    self._pushback[:0] = size  # 0xBB was noise; rescan from the next byte
                    garbage_budget = self._skip(1, garbage_budget)
                    continue
                data = self._take(length, deadline)
                if len(data) < length:
                    raise _AttemptFailed(f"truncated reply: {len(data)} of {length} data bytes",
                                         timed_out=True)
                return data
            if header == bytes([STATUS_REPLY]):
                status = self._take(1, deadline)
                if not status:
                    raise _AttemptFailed("truncated reply: status header without status", timed_out=True)
                if status[0] in STATUS_NAMES and status[0] != WRITE_SUCCESS:
                    self._handle_status(status[0])
                self._pushback[:0] = status
                garbage_budget = self._skip(1, garbage_budget)
                continue
            if not header:
                raise _AttemptFailed(f"no reply within {self.reply_timeout_s * 1e3:.0f} ms", timed_out=True)
            garbage_budget = self._skip(1, garbage_budget)

    def _write_reply(self, deadline: float) -> None:
        garbage_budget = 64
        while True:
            header = self._take(1, deadline)
            if header == bytes([STATUS_REPLY]):
                status = self._take(1, deadline)
                if not status:
                    raise _AttemptFailed("truncated acknowledge: header without status", timed_out=True)
                if status[0] == WRITE_SUCCESS:
                    return
                if status[0] in STATUS_NAMES:
                    self._handle_status(status[0])
                self._pushback[:0] = status
            elif not header:
                raise _AttemptFailed(f"no acknowledge within {self.reply_timeout_s * 1e3:.0f} ms",
                                     timed_out=True)
            garbage_budget = self._skip(1, garbage_budget)

    def _handle_status(self, status: int) -> None:
        name = STATUS_NAMES[status]
        self.stats.statuses[name] = self.stats.statuses.get(name, 0) + 1
        if status in RETRYABLE_STATUSES:
            raise _AttemptFailed(f"chip answered 0xEE 0x{status:02X} {name}", timed_out=False)
        raise ProtocolError(self.device, f"chip answered 0xEE 0x{status:02X} {name} to a request "
                            f"for {register_label(self._register)}", self._register)

    def _skip(self, count: int, budget: int) -> int:
        self.stats.garbage_bytes += count
        budget -= count
        if budget < 0:
            raise _AttemptFailed("no valid reply header in the byte stream (line noise? wrong baud "
                                 "rate?)", timed_out=False)
        return budget

    def _take(self, size: int, deadline: float) -> bytes:
        """Up to ``size`` bytes, fewer only if the deadline passes."""
        out = bytearray(self._pushback[:size])
        del self._pushback[:size]
        while len(out) < size:
            try:
                chunk = self.port.read(size - len(out))
            except OSError as exc:
                raise DeviceDisconnectedError(self.device, f"port failed while reading the reply for "
                                              f"{register_label(self._register)}: {exc}",
                                              self._register) from exc
            if chunk:
                out += chunk
            elif self.clock() >= deadline:
                break
            else:
                self.sleep(0.0005)
        return bytes(out)


def _check_request(device: str, register: int, length: int) -> None:
    if not isinstance(register, int) or not 0 <= register <= 0x7F:
        raise ValueError(f"{device}: register must be an int in 0x00..0x7F, got {register!r}")
    if not 1 <= length <= MAX_LENGTH:
        raise ValueError(f"{device}: transfer length must be 1..{MAX_LENGTH} bytes, got {length}")


def _is_write_timeout(exc: OSError) -> bool:
    serial = sys.modules.get("serial")  # only a pyserial port can raise pyserial's exception
    timeout_type = getattr(serial, "SerialTimeoutException", None) if serial else None
    return isinstance(exc, TimeoutError) or (timeout_type is not None and isinstance(exc, timeout_type))


class BNO055UART(BNO055):
    """A BNO055 strapped for UART (PS1 high, PS0 low), on a pyserial-like port at 115200 8N1.

    Parameters
    ----------
    port : pyserial-like
        e.g. ``serial.Serial("/dev/ttyUSB0", 115200, timeout=0.02)`` or an emulator.
    attempts, reply_timeout_s, retry_delay_s : see :class:`BNO055UartTransport`.
    sleep, clock : callable
        See :class:`~sensor.drivers.bno055.BNO055`.
    """

    def __init__(self, port: Any, *, attempts: int = 4, reply_timeout_s: float = 0.05,
                 retry_delay_s: float = 0.002, sleep: Callable[[float], None] = time.sleep,
                 clock: Callable[[], float] = time.monotonic):
        transport = BNO055UartTransport(port, attempts=attempts, reply_timeout_s=reply_timeout_s,
                                        retry_delay_s=retry_delay_s, sleep=sleep, clock=clock)
        super().__init__(transport, sleep=sleep, clock=clock)

    @property
    def link_stats(self) -> UartLinkStats:
        return self.transport.stats
