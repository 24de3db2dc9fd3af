"""Register-level BNO055 emulator (datasheet BST-BNO055-DS000 chapter 4), shared by the I2C bus
emulator and the UART port emulator.

Emulated: chip ids, register pages 0/1, OPR_MODE semantics (fusion outputs are zero outside
the fusion modes; the chip does not answer while it switches mode: 7 ms from CONFIG, 19 ms to
CONFIG, when a clock is given), configuration registers (UNIT_SEL, PWR_MODE, AXIS_MAP_*,
calibration 0x55..0x6A) writable only in CONFIG mode, unit selection for the acceleration
outputs, axis remap (invalid maps are refused and the previous one kept), SYS_TRIGGER reset
(650 ms boot, calibration lost), CALIB_STAT, SYS_STATUS.
Not emulated: the fusion itself (outputs are what the test sets), Euler angles, raw
magnetometer/gyroscope data, interrupts.
"""
from __future__ import annotations

import enum
import struct
from typing import Callable

import numpy as np

from sensor.emulators.fake_smbus import ChipBusy

_CONFIG_ONLY = {0x3B, 0x3E, 0x40, 0x41, 0x42, *range(0x43, 0x6B)}
_ANY_MODE = {0x07, 0x3D, 0x3F}
_FUSION_MODES = range(0x08, 0x0D)
_G = 9.80665


class WriteResult(enum.IntEnum):
    """UART status a register write produces (I2C silently ignores refused writes)."""

    OK = 0x01
    INVALID_ADDRESS = 0x04
    WRITE_DISABLED = 0x05


def _matrix_from_quaternion(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _quaternion_from_matrix(m: np.ndarray) -> np.ndarray:
    # Shepperd's method: branch on the largest diagonal term for numerical stability
    trace = np.trace(m)
    if trace > max(m[0, 0], m[1, 1], m[2, 2]):
        s = 2.0 * np.sqrt(1.0 + trace)
        q = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
    else:
        i = int(np.argmax(np.diag(m)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * np.sqrt(1.0 + m[i, i] - m[j, j] - m[k, k])
        q = [0.0] * 4
        q[0] = (m[k, j] - m[j, k]) / s
        q[1 + i] = 0.25 * s
        q[1 + j] = (m[j, i] + m[i, j]) / s
        q[1 + k] = (m[k, i] + m[i, k]) / s
    q = np.array(q)
    return q if q[0] >= 0 else -q


class BNO055Chip:
    """Emulated BNO055.

    Set the true outputs through the attributes; they are in the chip's own (un-remapped) frame:

    Attributes
    ----------
    quat_wxyz : (4,) float
        Orientation of the chip body in the world frame, unit quaternion (w, x, y, z).
    lin_acc_mps2 : (3,) float
        Linear acceleration, chip frame, m/s^2.
    gravity_mps2 : (3,) float
        Gravity, chip frame, m/s^2.
    calibration_status : tuple of 4 int
        (system, gyroscope, accelerometer, magnetometer), each 0..3.
    temperature_c : float

    Parameters
    ----------
    clock : callable or None
        Monotonic clock; when given, the chip refuses to answer during mode switches and boot.
    chip_id : int
        CHIP_ID register value (0xA0).
    """

    def __init__(self, *, clock: Callable[[], float] | None = None, chip_id: int = 0xA0):
        self.clock = clock
        self.chip_id = chip_id
        self.quat_wxyz = np.array([1.0, 0.0, 0.0, 0.0])
        self.lin_acc_mps2 = np.zeros(3)
        self.gravity_mps2 = np.array([0.0, 0.0, _G])
        self.calibration_status = (3, 3, 3, 3)
        self.temperature_c = 25.0
        self.resets = 0
        self._boot(busy_s=0.0)

    # -- bus side ---------------------------------------------------------------------------

    def read_block(self, register: int, length: int) -> bytes:
        self._check_awake()
        self._refresh_outputs()
        page = self.pages[self.page]
        end = min(register + length, 0x80)
        return bytes(page[register:end]) + bytes(register + length - end)

    def write_block(self, register: int, data: bytes) -> WriteResult:
        """Apply a burst write; a refused write changes nothing and returns its status."""
        self._check_awake()
        addresses = range(register, register + len(data))
        if any(address > 0x7F for address in addresses):
            return WriteResult.INVALID_ADDRESS
        if self.page == 0:
            for address in addresses:
                if address not in _ANY_MODE and address not in _CONFIG_ONLY:
                    return WriteResult.INVALID_ADDRESS
                if address in _CONFIG_ONLY and self.mode != 0:
                    return WriteResult.WRITE_DISABLED
        elif self.mode != 0 and any(address != 0x07 for address in addresses):
            return WriteResult.WRITE_DISABLED
        for address, value in zip(addresses, data):
            self._write(address, value)
        return WriteResult.OK

    # -- chip behaviour ---------------------------------------------------------------------

    @property
    def mode(self) -> int:
        return self.pages[0][0x3D] & 0x0F

    @property
    def calibration_bytes(self) -> bytes:
        """The 22 calibration registers 0x55..0x6A."""
        return bytes(self.pages[0][0x55:0x6B])

    def _boot(self, busy_s: float) -> None:
        page0, page1 = bytearray(0x80), bytearray(0x80)
        page0[0x00:0x07] = bytes([self.chip_id, 0xFB, 0x32, 0x0F, 0x11, 0x03, 0x15])
        page0[0x3B] = 0x80  # UNIT_SEL reset value
        page0[0x41] = 0x24  # AXIS_MAP_CONFIG: identity
        page1[0x07] = 0x01
        self.pages = (page0, page1)
        self.page = 0
        self._busy_until = (self.clock() + busy_s) if self.clock and busy_s else None

    def _check_awake(self) -> None:
        if self._busy_until is not None:
            if self.clock() < self._busy_until:
                raise ChipBusy()
            self._busy_until = None

    def _write(self, address: int, value: int) -> None:
        page = self.pages[self.page]
        if address == 0x07:
            if value in (0, 1):
                self.page = value
                self.pages[0][0x07] = value
                self.pages[1][0x07] = value
        elif address == 0x3D:
            new_mode = value & 0x0F
            if new_mode > 0x0C:
                return
            old_mode = self.mode
            page[0x3D] = new_mode
            if self.clock is not None and new_mode != old_mode:
                self._busy_until = self.clock() + (0.019 if new_mode == 0 else 0.007)
        elif address == 0x3F:
            if value & 0x20:
                self.resets += 1
                self._boot(busy_s=0.65)
        elif address in (0x41, 0x42):
            candidate = bytearray(page[0x41:0x43])
            candidate[address - 0x41] = value
            codes = [(candidate[0] >> (2 * i)) & 0b11 for i in range(3)]
            if sorted(codes) == [0, 1, 2]:
                page[0x41:0x43] = candidate  # otherwise the previous map stays
        else:
            page[address] = value

    def _remap(self) -> np.ndarray:
        config, sign = self.pages[0][0x41], self.pages[0][0x42]
        m = np.zeros((3, 3))
        for i in range(3):
            m[i, (config >> (2 * i)) & 0b11] = -1.0 if sign & (1 << (2 - i)) else 1.0
        return m

    def _refresh_outputs(self) -> None:
        page = self.pages[0]
        mode = self.mode
        fusion = mode in _FUSION_MODES
        m = self._remap()
        acceleration_lsb = 1.0 / (_G * 1e-3) if page[0x3B] & 0x01 else 100.0  # mg or m/s^2
        if fusion:
            q = self.quat_wxyz / np.linalg.norm(self.quat_wxyz)
            if np.linalg.det(m) > 0:  # the remapped frame's orientation; a mirror has none
                q = _quaternion_from_matrix(_matrix_from_quaternion(q) @ m.T)
            quaternion = np.round(q * (1 << 14))
            lin_acc = np.round(m @ self.lin_acc_mps2 * acceleration_lsb)
            gravity = np.round(m @ self.gravity_mps2 * acceleration_lsb)
        else:
            quaternion, lin_acc, gravity = np.zeros(4), np.zeros(3), np.zeros(3)
        accelerometer = lin_acc + gravity if mode != 0 else np.zeros(3)
        page[0x08:0x0E] = _int16s(accelerometer)
        page[0x20:0x34] = _int16s(np.concatenate([quaternion, lin_acc, gravity]))
        fahrenheit = bool(page[0x3B] & 0x10)
        temperature = self.temperature_c * 1.8 + 32.0 if fahrenheit else self.temperature_c
        page[0x34] = int(round(temperature * (2 if fahrenheit else 1))) & 0xFF
        s, g, a, mg = self.calibration_status
        page[0x35] = (s << 6) | (g << 4) | (a << 2) | mg
        page[0x39] = 0 if mode == 0 else (5 if fusion else 6)


def _int16s(values: np.ndarray) -> bytes:
    clipped = np.clip(values, -32768, 32767).astype(int)
    return struct.pack(f"<{len(clipped)}h", *clipped)
