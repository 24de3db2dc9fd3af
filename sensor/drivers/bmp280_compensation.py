"""Bosch BMP280 compensation: raw 20-bit ADC values to pascals and degrees Celsius.

Variant implemented: the datasheet's double-precision floating-point formulas (BMP280 data
sheet BST-BMP280-DS001, section 8.1, code revision 1.1), with one deliberate difference: the
fine temperature ``t_fine`` is carried into the pressure formula as a float, not truncated to a
32-bit integer. That is how the datasheet's worked example (section 3.12) is computed
(t_fine = 128422.2869948 -> p = 100653.27 Pa); truncating shifts the pressure by at most
~0.05 Pa (0.012 Pa in the example), far below the sensor's 0.16 Pa resolution.
"""
from __future__ import annotations

import struct
from dataclasses import dataclass

CALIBRATION_BYTES = 24  # registers 0x88..0x9F: dig_T1..dig_T3, dig_P1..dig_P9, little-endian


@dataclass(frozen=True)
class BMP280Calibration:
    """Factory trimming parameters read from registers 0x88..0x9F (datasheet table 17).

    ``dig_T1`` and ``dig_P1`` are unsigned 16-bit, the others signed 16-bit.
    """

    dig_T1: int
    dig_T2: int
    dig_T3: int
    dig_P1: int
    dig_P2: int
    dig_P3: int
    dig_P4: int
    dig_P5: int
    dig_P6: int
    dig_P7: int
    dig_P8: int
    dig_P9: int

    _FORMAT = "<HhhHhhhhhhhh"

    @classmethod
    def from_bytes(cls, raw: bytes) -> "BMP280Calibration":
        """Decode the 24 calibration bytes, LSB first; ValueError for a wrong length or dig_P1 == 0."""
        if len(raw) != CALIBRATION_BYTES:
            raise ValueError(f"BMP280 calibration needs {CALIBRATION_BYTES} bytes, got {len(raw)}")
        calibration = cls(*struct.unpack(cls._FORMAT, bytes(raw)))
        if calibration.dig_P1 == 0:
            # The pressure formula divides by a multiple of dig_P1; an all-zero NVM image means the
            # chip has not finished copying its NVM or the bus returned zeros.
            raise ValueError("BMP280 calibration has dig_P1 == 0 (NVM not copied or bus reads zeros)")
        return calibration

    def to_bytes(self) -> bytes:
        """Encode as the 24 register bytes (for emulators and logs)."""
        return struct.pack(self._FORMAT, self.dig_T1, self.dig_T2, self.dig_T3, self.dig_P1,
                           self.dig_P2, self.dig_P3, self.dig_P4, self.dig_P5, self.dig_P6,
                           self.dig_P7, self.dig_P8, self.dig_P9)


#: The calibration of the datasheet's worked example (section 3.12).
DATASHEET_EXAMPLE_CALIBRATION = BMP280Calibration(
    dig_T1=27504, dig_T2=26435, dig_T3=-1000,
    dig_P1=36477, dig_P2=-10685, dig_P3=3024, dig_P4=2855, dig_P5=140, dig_P6=-7,
    dig_P7=15500, dig_P8=-14600, dig_P9=6000)


def compensate_temperature(adc_t: int, cal: BMP280Calibration) -> tuple[float, float]:
    """Raw temperature to degrees Celsius.

    Returns
    -------
    temperature_c : float
        Degrees Celsius.
    t_fine : float
        Fine temperature (5120 per degree C) that the pressure formula needs.
    """
    var1 = (adc_t / 16384.0 - cal.dig_T1 / 1024.0) * cal.dig_T2
    offset = adc_t / 131072.0 - cal.dig_T1 / 8192.0
    var2 = offset * offset * cal.dig_T3
    t_fine = var1 + var2
    return t_fine / 5120.0, t_fine


def compensate_pressure(adc_p: int, t_fine: float, cal: BMP280Calibration) -> float:
    """Raw pressure to pascals, given ``t_fine`` from :func:`compensate_temperature`.

    Raises ValueError when the calibration makes the formula divide by zero.
    """
    var1 = t_fine / 2.0 - 64000.0
    var2 = var1 * var1 * cal.dig_P6 / 32768.0
    var2 = var2 + var1 * cal.dig_P5 * 2.0
    var2 = var2 / 4.0 + cal.dig_P4 * 65536.0
    var1 = (cal.dig_P3 * var1 * var1 / 524288.0 + cal.dig_P2 * var1) / 524288.0
    var1 = (1.0 + var1 / 32768.0) * cal.dig_P1
    if var1 == 0.0:
        raise ValueError("BMP280 pressure compensation divides by zero (check calibration)")
    p = 1048576.0 - adc_p
    p = (p - var2 / 4096.0) * 6250.0 / var1
    var1 = cal.dig_P9 * p * p / 2147483648.0
    var2 = p * cal.dig_P8 / 32768.0
    return p + (var1 + var2 + cal.dig_P7) / 16.0
