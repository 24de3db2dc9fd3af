"""Register-level BMP280 emulator.

Holds the register map of a BMP280 (datasheet BST-BMP280-DS001 chapter 4) and produces raw ADC
values for a settable true pressure and temperature. The raw values are found by inverting the
datasheet's *integer* compensation (32-bit temperature, 64-bit pressure, section 3.11.3) by
bisection, a code path independent of the driver's floating-point compensation.

Emulated: chip id, soft reset (registers to reset values, im_update busy for a few status
reads), ctrl_meas / config, forced mode (measuring busy for a few status reads, then the result
lands and the chip returns to sleep), normal mode (one conversion per burst read of the data
registers), oversampling resolution (16 + osrs - 1 bits without IIR filter, 20 bits with), the
IIR filter (reset when config is written) and shadowing of a burst read.
Not emulated: real conversion timing, the SPI interface.
"""
from __future__ import annotations

import numpy as np

from sensor.drivers.bmp280_compensation import DATASHEET_EXAMPLE_CALIBRATION, BMP280Calibration

SKIPPED = 0x80000


def fine_temperature_int32(adc_t: int, cal: BMP280Calibration) -> int:
    """Datasheet ``bmp280_compensate_T_int32``: t_fine (5120 per degree C)."""
    var1 = (((adc_t >> 3) - (cal.dig_T1 << 1)) * cal.dig_T2) >> 11
    delta = (adc_t >> 4) - cal.dig_T1
    var2 = (((delta * delta) >> 12) * cal.dig_T3) >> 14
    return var1 + var2


def temperature_centi_c(t_fine: int) -> int:
    """Temperature in 0.01 degree C from t_fine (datasheet integer formula)."""
    return (t_fine * 5 + 128) >> 8


def pressure_q24_8_int64(adc_p: int, t_fine: int, cal: BMP280Calibration) -> int:
    """Datasheet ``bmp280_compensate_P_int64``: pressure in Pa as Q24.8 (divide by 256)."""
    var1 = t_fine - 128000
    var2 = var1 * var1 * cal.dig_P6
    var2 = var2 + ((var1 * cal.dig_P5) << 17)
    var2 = var2 + (cal.dig_P4 << 35)
    var1 = ((var1 * var1 * cal.dig_P3) >> 8) + ((var1 * cal.dig_P2) << 12)
    var1 = (((1 << 47) + var1) * cal.dig_P1) >> 33
    if var1 == 0:
        return 0
    numerator = (((1048576 - adc_p) << 31) - var2) * 3125
    p = abs(numerator) // abs(var1) * (1 if (numerator >= 0) == (var1 > 0) else -1)  # C division
    var1 = (cal.dig_P9 * (p >> 13) * (p >> 13)) >> 25
    var2 = (cal.dig_P8 * p) >> 19
    return ((p + var1 + var2) >> 8) + (cal.dig_P7 << 4)


def _bisect(function, target: float, increasing: bool) -> int:
    """The 20-bit integer x whose monotonic ``function(x)`` is closest to ``target``."""
    low, high = 0, (1 << 20) - 1
    while high - low > 1:
        middle = (low + high) // 2
        if (function(middle) < target) == increasing:
            low = middle
        else:
            high = middle
    return min((low, high), key=lambda x: abs(function(x) - target))


def raw_temperature_for(temperature_c: float, cal: BMP280Calibration) -> int:
    """adc_T whose integer compensation is nearest ``temperature_c``."""
    return _bisect(lambda adc: fine_temperature_int32(adc, cal), temperature_c * 5120.0, True)


def raw_pressure_for(pressure_pa: float, t_fine: int, cal: BMP280Calibration) -> int:
    """adc_P whose integer compensation at ``t_fine`` is nearest ``pressure_pa``."""
    return _bisect(lambda adc: pressure_q24_8_int64(adc, t_fine, cal), pressure_pa * 256.0, False)


_FILTER_COEFFICIENTS = (1, 2, 4, 8, 16, 16, 16, 16)
_RESET_REGISTERS = {0xF3: 0x00, 0xF4: 0x00, 0xF5: 0x00, 0xF7: 0x80, 0xF8: 0x00, 0xF9: 0x00,
                    0xFA: 0x80, 0xFB: 0x00, 0xFC: 0x00}


class BMP280Chip:
    """Emulated BMP280.

    Parameters
    ----------
    pressure_pa, temperature_c : float
        True pressure (pascals) and temperature (degrees C); settable attributes.
    calibration : BMP280Calibration
        NVM trimming; the datasheet's worked example by default.
    chip_id : int
        Value of register 0xD0 (0x58 for a BMP280; 0x60 emulates a BME280).
    noise_pa : float
        Standard deviation of Gaussian noise added to the true pressure per conversion, Pa.
    busy_reads : int
        Status reads during which im_update (after reset) or measuring (forced mode) stays set.
    seed : int
        Noise generator seed.
    """

    def __init__(self, *, pressure_pa: float = 101325.0, temperature_c: float = 25.0,
                 calibration: BMP280Calibration = DATASHEET_EXAMPLE_CALIBRATION,
                 chip_id: int = 0x58, noise_pa: float = 0.0, busy_reads: int = 2, seed: int = 0):
        self.pressure_pa = pressure_pa
        self.temperature_c = temperature_c
        self.calibration = calibration
        self.noise_pa = noise_pa
        self.busy_reads = busy_reads
        self.rng = np.random.default_rng(seed)
        self.registers = bytearray(256)
        self.registers[0xD0] = chip_id
        self.registers[0x88:0xA0] = calibration.to_bytes()
        self.conversions = 0
        self._power_on()

    # -- bus side ---------------------------------------------------------------------------

    def read_block(self, register: int, length: int) -> bytes:
        if register <= 0xF7 < register + length:
            if self.mode == 3:
                self._convert()
        if register <= 0xF3 < register + length:
            self._status_read()
        end = min(register + length, 256)
        return bytes(self.registers[register:end]) + bytes(register + length - end)

    def write_block(self, register: int, data: bytes) -> None:
        for offset, value in enumerate(data):
            self._write(register + offset, value)

    # -- chip behaviour ---------------------------------------------------------------------

    @property
    def mode(self) -> int:
        """ctrl_meas.mode: 0 sleep, 1 or 2 forced, 3 normal."""
        return self.registers[0xF4] & 0b11

    def _power_on(self) -> None:
        for address, value in _RESET_REGISTERS.items():
            self.registers[address] = value
        self._nvm_busy = 0
        self._measuring = 0
        self._filter_memory: tuple[float, float] | None = None

    def _write(self, register: int, value: int) -> None:
        if register == 0xE0:
            if value == 0xB6:
                self._power_on()
                self._nvm_busy = self.busy_reads
        elif register == 0xF4:
            self.registers[0xF4] = value
            if self.mode in (1, 2):
                self._measuring = self.busy_reads
                if self._measuring == 0:
                    self._finish_forced()
        elif register == 0xF5:
            self.registers[0xF5] = value & 0b11111101  # bit 1 is reserved
            self._filter_memory = None  # writing the filter setting resets the filter
        # id, calibration, status and data registers are read-only: writes are ignored

    def _status_read(self) -> None:
        status = 0
        if self._nvm_busy:
            self._nvm_busy -= 1
            status |= 0x01
        if self._measuring:
            self._measuring -= 1
            status |= 0x08
            if self._measuring == 0:
                self._finish_forced()
        self.registers[0xF3] = status

    def _finish_forced(self) -> None:
        self._convert()
        self.registers[0xF4] &= 0b11111100  # back to sleep

    def _convert(self) -> None:
        self.conversions += 1
        cal = self.calibration
        osrs_t = (self.registers[0xF4] >> 5) & 0b111
        osrs_p = (self.registers[0xF4] >> 2) & 0b111
        coefficient = _FILTER_COEFFICIENTS[(self.registers[0xF5] >> 2) & 0b111]
        adc_t = raw_temperature_for(self.temperature_c, cal)
        pressure = self.pressure_pa + (self.rng.normal(0.0, self.noise_pa) if self.noise_pa else 0.0)
        adc_p = raw_pressure_for(pressure, fine_temperature_int32(adc_t, cal), cal)
        if self._filter_memory is None or coefficient == 1:
            self._filter_memory = (float(adc_p), float(adc_t))
        else:
            old_p, old_t = self._filter_memory
            self._filter_memory = ((old_p * (coefficient - 1) + adc_p) / coefficient,
                                   (old_t * (coefficient - 1) + adc_t) / coefficient)
        filtered_p, filtered_t = (int(round(v)) for v in self._filter_memory)
        self._store(0xF7, filtered_p, osrs_p, coefficient)
        self._store(0xFA, filtered_t, osrs_t, coefficient)

    def _store(self, register: int, value: int, osrs: int, coefficient: int) -> None:
        if osrs == 0:
            value = SKIPPED
        elif coefficient == 1:
            dropped_bits = 20 - (15 + min(osrs, 5))  # 16 bit at x1 ... 20 bit at x16
            value = (value >> dropped_bits) << dropped_bits
        self.registers[register:register + 3] = bytes([(value >> 12) & 0xFF, (value >> 4) & 0xFF,
                                                       (value << 4) & 0xF0])
