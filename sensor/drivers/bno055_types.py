"""Plain value types the BNO055 driver reads and writes: units, axis remap, calibration."""
from __future__ import annotations

import struct
from dataclasses import dataclass

import numpy as np

from sensor.drivers.bno055_registers import CALIBRATION_LENGTH

_ACCELERATION = ("m/s^2", "mg")
_ANGULAR_RATE = ("deg/s", "rad/s")
_EULER = ("deg", "rad")
_TEMPERATURE = ("C", "F")


@dataclass(frozen=True)
class UnitSelection:
    """The UNIT_SEL register (0x3B) as names.

    Bits: 0 acceleration (m/s^2 | mg), 1 angular rate (deg/s | rad/s), 2 Euler angles (deg | rad),
    4 temperature (C | F), 7 orientation convention (Windows | Android). The driver converts
    every reading to SI whatever is selected; this only changes the chip's raw output.
    """

    acceleration: str = "m/s^2"
    angular_rate: str = "rad/s"
    euler: str = "rad"
    temperature: str = "C"
    android_orientation: bool = False

    def __post_init__(self):
        for name, allowed in (("acceleration", _ACCELERATION), ("angular_rate", _ANGULAR_RATE),
                              ("euler", _EULER), ("temperature", _TEMPERATURE)):
            if getattr(self, name) not in allowed:
                raise ValueError(f"UnitSelection.{name}={getattr(self, name)!r}; allowed: {allowed}")

    def to_byte(self) -> int:
        return ((_ACCELERATION.index(self.acceleration))
                | (_ANGULAR_RATE.index(self.angular_rate) << 1)
                | (_EULER.index(self.euler) << 2)
                | (_TEMPERATURE.index(self.temperature) << 4)
                | (int(self.android_orientation) << 7))

    @classmethod
    def from_byte(cls, value: int) -> "UnitSelection":
        return cls(acceleration=_ACCELERATION[value & 1], angular_rate=_ANGULAR_RATE[(value >> 1) & 1],
                   euler=_EULER[(value >> 2) & 1], temperature=_TEMPERATURE[(value >> 4) & 1],
                   android_orientation=bool(value & 0x80))


_AXIS_CODES = {"x": 0, "y": 1, "z": 2}

#: Mounting placements P0..P7 of datasheet section 3.4: (AXIS_MAP_CONFIG, AXIS_MAP_SIGN).
PLACEMENTS = {"P0": (0x21, 0x04), "P1": (0x24, 0x00), "P2": (0x24, 0x06), "P3": (0x21, 0x02),
              "P4": (0x24, 0x03), "P5": (0x21, 0x01), "P6": (0x21, 0x07), "P7": (0x24, 0x05)}


@dataclass(frozen=True)
class AxisRemap:
    """Axis remap (AXIS_MAP_CONFIG 0x41, AXIS_MAP_SIGN 0x42).

    Remapped axis i reads ``signs[i] * device_axis[axes[i]]``: ``axes=("y", "x", "z")`` swaps
    x and y. The default is the identity (placement P1).
    """

    axes: tuple[str, str, str] = ("x", "y", "z")
    signs: tuple[int, int, int] = (1, 1, 1)

    def __post_init__(self):
        if len(self.axes) != 3 or sorted(self.axes) != ["x", "y", "z"]:
            raise ValueError(f"AxisRemap.axes must be a permutation of ('x', 'y', 'z'), got {self.axes!r}")
        if len(self.signs) != 3 or any(sign not in (1, -1) for sign in self.signs):
            raise ValueError(f"AxisRemap.signs must be three values of +1 or -1, got {self.signs!r}")

    @classmethod
    def placement(cls, name: str) -> "AxisRemap":
        """One of the datasheet's mounting placements ``"P0"`` .. ``"P7"``."""
        if name not in PLACEMENTS:
            raise ValueError(f"unknown placement {name!r}; expected one of {sorted(PLACEMENTS)}")
        return cls.from_bytes(*PLACEMENTS[name])

    def to_bytes(self) -> tuple[int, int]:
        """``(AXIS_MAP_CONFIG, AXIS_MAP_SIGN)`` register values."""
        config = sum(_AXIS_CODES[axis] << (2 * i) for i, axis in enumerate(self.axes))
        sign = sum(1 << (2 - i) for i, s in enumerate(self.signs) if s < 0)
        return config, sign

    @classmethod
    def from_bytes(cls, config: int, sign: int) -> "AxisRemap":
        codes = [(config >> (2 * i)) & 0b11 for i in range(3)]
        if 3 in codes:
            raise ValueError(f"AXIS_MAP_CONFIG 0x{config:02X} uses the invalid axis code 0b11")
        axes = tuple("xyz"[code] for code in codes)
        signs = tuple(-1 if sign & (1 << (2 - i)) else 1 for i in range(3))
        return cls(axes, signs)

    def matrix(self) -> np.ndarray:
        """(3, 3) matrix M with ``v_remapped = M @ v_device``."""
        m = np.zeros((3, 3))
        for i, (axis, sign) in enumerate(zip(self.axes, self.signs)):
            m[i, _AXIS_CODES[axis]] = sign
        return m


@dataclass(frozen=True)
class CalibrationStatus:
    """CALIB_STAT (0x35): each subsystem from 0 (uncalibrated) to 3 (fully calibrated)."""

    system: int
    gyroscope: int
    accelerometer: int
    magnetometer: int

    @classmethod
    def from_byte(cls, value: int) -> "CalibrationStatus":
        return cls((value >> 6) & 3, (value >> 4) & 3, (value >> 2) & 3, value & 3)

    @property
    def fully_calibrated(self) -> bool:
        return min(self.system, self.gyroscope, self.accelerometer, self.magnetometer) == 3


@dataclass(frozen=True)
class CalibrationProfile:
    """The 22 calibration bytes 0x55..0x6A, as raw signed 16-bit register values.

    Offsets are in the chip's LSB for the unit selection active when they were read; restore a
    profile with the same :class:`UnitSelection`. Store it with :meth:`to_hex`.
    """

    accelerometer_offset: tuple[int, int, int]
    magnetometer_offset: tuple[int, int, int]
    gyroscope_offset: tuple[int, int, int]
    accelerometer_radius: int
    magnetometer_radius: int

    _FORMAT = "<11h"

    def __post_init__(self):
        values = self._values()
        if len(values) != 11 or any(not isinstance(v, (int, np.integer)) or not -32768 <= v <= 32767
                                    for v in values):
            raise ValueError(f"CalibrationProfile values must be 11 signed 16-bit ints, got {values}")

    def _values(self) -> list[int]:
        return [*self.accelerometer_offset, *self.magnetometer_offset, *self.gyroscope_offset,
                self.accelerometer_radius, self.magnetometer_radius]

    def to_bytes(self) -> bytes:
        return struct.pack(self._FORMAT, *self._values())

    @classmethod
    def from_bytes(cls, raw: bytes) -> "CalibrationProfile":
        if len(raw) != CALIBRATION_LENGTH:
            raise ValueError(f"BNO055 calibration profile needs {CALIBRATION_LENGTH} bytes, got {len(raw)}")
        v = struct.unpack(cls._FORMAT, bytes(raw))
        return cls(tuple(v[0:3]), tuple(v[3:6]), tuple(v[6:9]), v[9], v[10])

    def to_hex(self) -> str:
        return self.to_bytes().hex()

    @classmethod
    def from_hex(cls, text: str) -> "CalibrationProfile":
        try:
            raw = bytes.fromhex(text)
        except ValueError as exc:
            raise ValueError(f"BNO055 calibration profile: not a hex string: {text!r}") from exc
        return cls.from_bytes(raw)


@dataclass(frozen=True)
class FusionSample:
    """One burst read of the fusion outputs (registers 0x20..0x33).

    Attributes
    ----------
    quat_wxyz : (4,) float
        Orientation of the (remapped) sensor frame in the fusion world frame, unit quaternion.
    lin_acc_mps2 : (3,) float
        Linear acceleration (gravity removed), sensor frame, m/s^2.
    gravity_mps2 : (3,) float
        Gravity vector, sensor frame, m/s^2.
    """

    quat_wxyz: np.ndarray
    lin_acc_mps2: np.ndarray
    gravity_mps2: np.ndarray
