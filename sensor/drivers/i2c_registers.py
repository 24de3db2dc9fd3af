"""Register access to one chip on an I2C bus, with bounded retries and named errors.

The bus is any object with smbus2's ``SMBus`` methods (``read_i2c_block_data``,
``write_byte_data``, ``write_i2c_block_data``): an ``smbus2.SMBus(1)`` or an emulator. Nothing
here imports smbus2.
"""
from __future__ import annotations

import errno
import time
from typing import Any, Callable

from sensor.drivers.errors import BusError, DeviceTimeoutError

SMBUS_BLOCK_MAX = 32  # bytes per SMBus block transfer (I2C_SMBUS_BLOCK_MAX in Linux)


class I2CRegisters:
    """Read and write byte registers of the chip at ``address``.

    Parameters
    ----------
    bus : smbus2.SMBus-like
        The bus object.
    address : int
        7-bit I2C address, 0x03..0x77.
    device : str
        Chip name used in error messages, e.g. ``"BMP280"``.
    attempts : int
        Transfers tried before giving up (>= 1); a NACK from a busy chip usually clears on retry.
    retry_delay_s : float
        Pause between attempts, seconds.
    sleep : callable
        ``sleep(seconds)``; injectable so tests do not wait.
    """

    def __init__(self, bus: Any, address: int, device: str, *, attempts: int = 3,
                 retry_delay_s: float = 0.001, sleep: Callable[[float], None] = time.sleep):
        if not isinstance(address, int) or not 0x03 <= address <= 0x77:
            raise ValueError(f"{device}: I2C address must be an int in 0x03..0x77, got {address!r}")
        if attempts < 1:
            raise ValueError(f"{device}: attempts must be >= 1, got {attempts}")
        for method in ("read_i2c_block_data", "write_byte_data", "write_i2c_block_data"):
            if not callable(getattr(bus, method, None)):
                raise TypeError(f"{device}: bus object {bus!r} lacks SMBus method {method}()")
        self.bus = bus
        self.address = address
        self.device = f"{device} at I2C 0x{address:02X}"
        self.attempts = attempts
        self.retry_delay_s = retry_delay_s
        self.sleep = sleep
        self.retries_used = 0  # transfers that failed but succeeded on a later attempt

    def read(self, register: int, length: int) -> bytes:
        """Burst-read ``length`` bytes starting at ``register`` (auto-increment)."""
        _check_register(self.device, register)
        if not 1 <= length <= 256 - register:
            raise ValueError(f"{self.device}: cannot read {length} bytes from register 0x{register:02X}")
        out = bytearray()
        for start in range(register, register + length, SMBUS_BLOCK_MAX):
            count = min(SMBUS_BLOCK_MAX, register + length - start)
            chunk = self._transfer(start, lambda: self.bus.read_i2c_block_data(self.address, start, count))
            if len(chunk) != count:
                raise BusError(self.device, f"short read: {len(chunk)} of {count} bytes", start)
            out += bytes(chunk)
        return bytes(out)

    def read_byte(self, register: int) -> int:
        """Read one register."""
        return self.read(register, 1)[0]

    def write(self, register: int, data: bytes | int) -> None:
        """Write one byte or a burst of bytes starting at ``register``."""
        _check_register(self.device, register)
        payload = bytes([data]) if isinstance(data, int) else bytes(data)
        if not 1 <= len(payload) <= SMBUS_BLOCK_MAX:
            raise ValueError(f"{self.device}: write of {len(payload)} bytes to 0x{register:02X} "
                             f"(1..{SMBUS_BLOCK_MAX} allowed)")
        if len(payload) == 1:
            self._transfer(register, lambda: self.bus.write_byte_data(self.address, register, payload[0]))
        else:
            self._transfer(register,
                           lambda: self.bus.write_i2c_block_data(self.address, register, list(payload)))

    def _transfer(self, register: int, action: Callable[[], Any]) -> Any:
        for attempt in range(1, self.attempts + 1):
            try:
                result = action()
            except OSError as exc:
                last = exc
                if attempt < self.attempts:
                    self.sleep(self.retry_delay_s)
                continue
            if attempt > 1:
                self.retries_used += 1
            return result
        reason = f"{type(last).__name__}: {last} (after {self.attempts} attempts)"
        if isinstance(last, TimeoutError) or getattr(last, "errno", None) == errno.ETIMEDOUT:
            raise DeviceTimeoutError(self.device, reason, register) from last
        raise BusError(self.device, reason, register) from last


def _check_register(device: str, register: int) -> None:
    if not isinstance(register, int) or not 0 <= register <= 0xFF:
        raise ValueError(f"{device}: register must be an int in 0x00..0xFF, got {register!r}")
