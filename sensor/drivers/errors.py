"""Exceptions raised by the hardware drivers.

Every error names the device (chip and transport, e.g. ``"BNO055 over UART"`` or
``"BMP280 at I2C 0x76"``) and, where one is involved, the register, so that a log line is
enough to find the faulty wire or setting.
"""
from __future__ import annotations


class DeviceError(Exception):
    """Base class: something went wrong talking to a sensor chip.

    Attributes
    ----------
    device : str
        Chip and transport, e.g. ``"BMP280 at I2C 0x76"``.
    register : int or None
        Register address involved, if any.
    """

    def __init__(self, device: str, message: str, register: int | None = None):
        self.device = device
        self.register = register
        where = f" (register 0x{register:02X})" if register is not None else ""
        super().__init__(f"{device}{where}: {message}")


class ChipIdError(DeviceError):
    """The chip-id register held an unexpected value (wrong chip, wrong address, dead bus)."""

    def __init__(self, device: str, register: int, found: int, expected: int, hint: str = ""):
        self.found = found
        self.expected = expected
        message = f"chip id 0x{found:02X} read, expected 0x{expected:02X}"
        super().__init__(device, message + (f"; {hint}" if hint else ""), register)


class BusError(DeviceError, OSError):
    """A bus transfer kept failing (NACK, I/O error) after the allowed retries."""


class DeviceTimeoutError(DeviceError, TimeoutError):
    """The device did not answer (or answered only partly) within the allowed time and retries."""


class DeviceDisconnectedError(DeviceError, ConnectionError):
    """The port or bus went away (cable pulled, USB adapter reset)."""


class ProtocolError(DeviceError):
    """The device answered with a non-retryable error status or a malformed reply."""
