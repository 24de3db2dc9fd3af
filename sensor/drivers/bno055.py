"""Bosch BNO055 absolute-orientation IMU driver, independent of the transport.

:class:`BNO055` talks to a *transport* (anything with ``device``, ``read(register, length)`` and
``write(register, data)``); :class:`BNO055I2C` builds it on an smbus2-like bus, and
:class:`sensor.drivers.bno055_uart.BNO055UART` on a pyserial-like port. All readings come back
in SI units whatever UNIT_SEL holds.
"""
from __future__ import annotations

import contextlib
import struct
import time
from typing import Any, Callable, Iterator, Protocol

import numpy as np

from sensor.drivers import bno055_registers as reg
from sensor.drivers.bno055_registers import OperationMode, register_label
from sensor.drivers.bno055_types import (AxisRemap, CalibrationProfile, CalibrationStatus,
                                         FusionSample, UnitSelection)
from sensor.drivers.errors import ChipIdError, DeviceError, DeviceTimeoutError
from sensor.drivers.i2c_registers import I2CRegisters


class RegisterTransport(Protocol):
    """What :class:`BNO055` needs from a bus."""

    device: str

    def read(self, register: int, length: int) -> bytes: ...

    def write(self, register: int, data: bytes | int) -> None: ...


class BNO055:
    """A BNO055 reached through ``transport``.

    The constructor checks the chip id, selects register page 0 and reads the current
    operation mode and unit selection; it changes no setting.

    Parameters
    ----------
    transport : RegisterTransport
        Register access (I2C or UART).
    sleep, clock : callable
        ``sleep(seconds)`` and monotonic ``clock() -> seconds``; injectable so that tests do not
        wait for the datasheet's mode-switch delays.
    """

    def __init__(self, transport: RegisterTransport, *, sleep: Callable[[float], None] = time.sleep,
                 clock: Callable[[], float] = time.monotonic):
        self.transport = transport
        self.sleep = sleep
        self.clock = clock
        self._page: int | None = None
        self.check_chip_id()
        self.select_page(0)
        self.mode = self._read_mode()
        self.units = UnitSelection.from_byte(self._read_byte(reg.UNIT_SEL))

    @property
    def device(self) -> str:
        return self.transport.device

    # -- identification, pages, modes -------------------------------------------------------

    def check_chip_id(self) -> None:
        """Raise :class:`ChipIdError` unless CHIP_ID reads 0xA0."""
        found = self.transport.read(reg.CHIP_ID, 1)[0]
        if found != reg.CHIP_ID_VALUE:
            raise ChipIdError(self.device, reg.CHIP_ID, found, reg.CHIP_ID_VALUE,
                              "is the chip still booting (650 ms after power-on)?")

    def select_page(self, page: int) -> None:
        """Select register page 0 (data, configuration) or 1 (sensor settings)."""
        if page not in (0, 1):
            raise ValueError(f"{self.device}: register page must be 0 or 1, got {page!r}")
        if page != self._page:
            self.transport.write(reg.PAGE_ID, page)
            self._page = page

    def set_mode(self, mode: OperationMode | int) -> None:
        """Switch the operation mode and wait the datasheet's switching time.

        CONFIG -> any operation mode takes 7 ms, any operation mode -> CONFIG 19 ms.
        """
        try:
            mode = OperationMode(mode)
        except ValueError:
            raise ValueError(f"{self.device}: unknown operation mode {mode!r}") from None
        if mode == self.mode:
            return
        self.select_page(0)
        self.transport.write(reg.OPR_MODE, int(mode))
        self.sleep(reg.OPERATION_TO_CONFIG_S if mode == OperationMode.CONFIG
                   else reg.CONFIG_TO_OPERATION_S)
        self.mode = mode

    @contextlib.contextmanager
    def config_mode(self) -> Iterator[None]:
        """Enter CONFIG mode for the block, then restore the previous mode."""
        previous = self.mode
        self.set_mode(OperationMode.CONFIG)
        try:
            yield
        finally:
            self.set_mode(previous)

    def reset(self, boot_timeout_s: float = 1.0) -> None:
        """System reset (SYS_TRIGGER.RST_SYS); waits for the boot, after which the chip is in CONFIG
        mode with default units and no calibration."""
        self.select_page(0)
        try:
            self.transport.write(reg.SYS_TRIGGER, reg.SYS_TRIGGER_RESET)
        except DeviceTimeoutError:
            pass  # over UART the chip may reboot before it acknowledges
        self.sleep(reg.POWER_ON_RESET_S)
        deadline = self.clock() + boot_timeout_s
        while True:
            try:
                self.check_chip_id()
                break
            except (DeviceError, OSError):
                if self.clock() > deadline:
                    raise
                self.sleep(0.01)
        self._page = None
        self.select_page(0)
        self.mode = self._read_mode()
        self.units = UnitSelection.from_byte(self._read_byte(reg.UNIT_SEL))

    # -- configuration (CONFIG mode is entered and left automatically) -----------------------

    def set_units(self, units: UnitSelection = UnitSelection()) -> None:
        """Write UNIT_SEL; readings stay in SI whatever is chosen."""
        with self.config_mode():
            self._write_verified(reg.UNIT_SEL, bytes([units.to_byte()]))
        self.units = units

    def set_axis_remap(self, remap: AxisRemap) -> None:
        """Write AXIS_MAP_CONFIG and AXIS_MAP_SIGN (e.g. ``AxisRemap.placement("P5")``)."""
        with self.config_mode():
            self._write_verified(reg.AXIS_MAP_CONFIG, bytes(remap.to_bytes()))

    def axis_remap(self) -> AxisRemap:
        self.select_page(0)
        config, sign = self.transport.read(reg.AXIS_MAP_CONFIG, 2)
        return AxisRemap.from_bytes(config, sign)

    def read_calibration(self) -> CalibrationProfile:
        """Read the 22 offset/radius bytes (in CONFIG mode, as the datasheet requires)."""
        with self.config_mode():
            return CalibrationProfile.from_bytes(
                self.transport.read(reg.CALIBRATION_START, reg.CALIBRATION_LENGTH))

    def write_calibration(self, profile: CalibrationProfile) -> None:
        """Restore a saved profile (in CONFIG mode), verified by reading it back."""
        with self.config_mode():
            self._write_verified(reg.CALIBRATION_START, profile.to_bytes())

    # -- readings ---------------------------------------------------------------------------

    def calibration_status(self) -> CalibrationStatus:
        return CalibrationStatus.from_byte(self._read_byte(reg.CALIB_STAT))

    def quaternion(self) -> tuple[float, float, float, float]:
        """Orientation ``(w, x, y, z)`` of the sensor frame in the fusion world frame."""
        self._require_fusion("quaternion")
        raw = self._read_fusion(reg.QUA_DATA, 4)
        return tuple(float(v) for v in self._quaternion_from_raw(raw, reg.QUA_DATA))

    def linear_acceleration(self) -> np.ndarray:
        """(3,) float: acceleration without gravity, sensor frame, m/s^2."""
        self._require_fusion("linear acceleration")
        return self._acceleration_from_raw(self._read_fusion(reg.LIA_DATA, 3))

    def gravity(self) -> np.ndarray:
        """(3,) float: gravity vector, sensor frame, m/s^2."""
        self._require_fusion("gravity")
        return self._acceleration_from_raw(self._read_fusion(reg.GRV_DATA, 3))

    def fusion_sample(self) -> FusionSample:
        """Quaternion, linear acceleration and gravity from one 20-byte burst (0x20..0x33)."""
        self._require_fusion("fusion sample")
        raw = self._read_fusion(reg.QUA_DATA, 10)
        return FusionSample(quat_wxyz=self._quaternion_from_raw(raw[:4], reg.QUA_DATA),
                            lin_acc_mps2=self._acceleration_from_raw(raw[4:7]),
                            gravity_mps2=self._acceleration_from_raw(raw[7:10]))

    # -- helpers ----------------------------------------------------------------------------

    def _read_byte(self, register: int) -> int:
        self.select_page(0)
        return self.transport.read(register, 1)[0]

    def _read_mode(self) -> OperationMode:
        value = self._read_byte(reg.OPR_MODE) & 0x0F
        try:
            return OperationMode(value)
        except ValueError:
            raise DeviceError(self.device, f"OPR_MODE holds the undefined mode 0x{value:X}",
                              reg.OPR_MODE) from None

    def _read_fusion(self, register: int, count: int) -> np.ndarray:
        self.select_page(0)
        return np.array(struct.unpack(f"<{count}h", self.transport.read(register, 2 * count)), float)

    def _require_fusion(self, what: str) -> None:
        if not self.mode.is_fusion:
            raise DeviceError(self.device, f"{what} needs a fusion mode (IMU, COMPASS, M4G, "
                              f"NDOF_FMC_OFF, NDOF); the chip is in {self.mode.name}", reg.OPR_MODE)

    def _quaternion_from_raw(self, raw: np.ndarray, register: int) -> np.ndarray:
        q = raw / reg.QUATERNION_LSB_PER_UNIT
        norm = float(np.linalg.norm(q))
        if not 0.9 < norm < 1.1:
            # all zeros right after a mode switch, before the fusion has produced an output
            raise DeviceError(self.device, f"quaternion has norm {norm:.3f}; fusion output not "
                              f"ready or corrupted", register)
        return q / norm

    def _acceleration_from_raw(self, raw: np.ndarray) -> np.ndarray:
        if self.units.acceleration == "mg":
            return raw / reg.ACC_LSB_PER_MG * 1e-3 * reg.STANDARD_GRAVITY_MPS2
        return raw / reg.ACC_LSB_PER_MPS2

    def _write_verified(self, register: int, data: bytes) -> None:
        self.select_page(0)
        self.transport.write(register, data)
        readback = self.transport.read(register, len(data))
        if readback != data:
            raise DeviceError(self.device, f"write to {register_label(register)} not accepted: "
                              f"wrote {data.hex(' ').upper()}, read back {readback.hex(' ').upper()}",
                              register)


class BNO055I2C(BNO055):
    """A BNO055 on an I2C bus (address 0x28, or 0x29 with COM3 high).

    Parameters
    ----------
    bus : smbus2.SMBus-like
    address : int
    attempts : int
        Tries per transfer before :class:`~sensor.drivers.errors.BusError`.
    sleep, clock : callable
        See :class:`BNO055`.
    """

    def __init__(self, bus: Any, address: int = 0x28, *, attempts: int = 3,
                 sleep: Callable[[float], None] = time.sleep,
                 clock: Callable[[], float] = time.monotonic):
        transport = I2CRegisters(bus, address, "BNO055", attempts=attempts, sleep=sleep)
        super().__init__(transport, sleep=sleep, clock=clock)
