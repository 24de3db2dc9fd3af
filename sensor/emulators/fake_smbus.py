"""An in-memory stand-in for ``smbus2.SMBus`` with chips attached at addresses."""
from __future__ import annotations

import errno
from typing import Protocol

from sensor.emulators.faults import Fault, FaultInjector


class RegisterChip(Protocol):
    """What a chip emulator offers the bus: burst reads and writes with auto-increment."""

    def read_block(self, register: int, length: int) -> bytes: ...

    def write_block(self, register: int, data: bytes) -> None: ...


class ChipBusy(Exception):
    """Raised by a chip emulator that would not acknowledge right now (booting, switching mode)."""


class FakeSMBus:
    """smbus2.SMBus look-alike.

    Parameters
    ----------
    chips : dict[int, RegisterChip]
        Chip emulators by 7-bit address.

    Attributes
    ----------
    faults : FaultInjector
        Faults for coming transfers (NACK, IO_ERROR, BUS_TIMEOUT, DISCONNECT).
    log : list of tuple
        Every transfer as ``(operation, address, register, length)``.
    """

    def __init__(self, chips: dict[int, RegisterChip] | None = None):
        self.chips: dict[int, RegisterChip] = dict(chips or {})
        self.faults = FaultInjector()
        self.log: list[tuple[str, int, int, int]] = []
        self.closed = False

    def attach(self, address: int, chip: RegisterChip) -> None:
        self.chips[address] = chip

    def read_byte_data(self, i2c_addr: int, register: int) -> int:
        return self._transfer("read", i2c_addr, register, 1)[0]

    def write_byte_data(self, i2c_addr: int, register: int, value: int) -> None:
        if not 0 <= value <= 0xFF:
            raise ValueError(f"byte value out of range: {value}")
        self._transfer("write", i2c_addr, register, 1, bytes([value]))

    def read_i2c_block_data(self, i2c_addr: int, register: int, length: int) -> list[int]:
        if not 1 <= length <= 32:
            raise ValueError(f"SMBus block length must be 1..32, got {length}")
        return list(self._transfer("read", i2c_addr, register, length))

    def write_i2c_block_data(self, i2c_addr: int, register: int, data: list[int]) -> None:
        if not 1 <= len(data) <= 32:
            raise ValueError(f"SMBus block length must be 1..32, got {len(data)}")
        self._transfer("write", i2c_addr, register, len(data), bytes(data))

    def close(self) -> None:
        self.closed = True

    def __enter__(self) -> "FakeSMBus":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _transfer(self, operation: str, address: int, register: int, length: int,
                  data: bytes = b"") -> bytes:
        if self.closed:
            raise OSError(errno.EBADF, "bus is closed")
        self.log.append((operation, address, register, length))
        fault = self.faults.take(register)
        if fault is Fault.DISCONNECT:
            raise OSError(errno.ENXIO, "No such device or address")
        if fault is Fault.NACK:
            raise OSError(errno.EREMOTEIO, "Remote I/O error")
        if fault is Fault.IO_ERROR:
            raise OSError(errno.EIO, "Input/output error")
        if fault is Fault.BUS_TIMEOUT:
            raise TimeoutError(errno.ETIMEDOUT, "Connection timed out")
        if fault is not None:
            raise ValueError(f"fault {fault.name} does not apply to an I2C bus")
        chip = self.chips.get(address)
        if chip is None:
            raise OSError(errno.EREMOTEIO, "Remote I/O error")  # nobody acknowledges the address
        try:
            if operation == "read":
                return bytes(chip.read_block(register, length))
            chip.write_block(register, data)
            return b""
        except ChipBusy:
            raise OSError(errno.EREMOTEIO, "Remote I/O error") from None
