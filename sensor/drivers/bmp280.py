"""Bosch BMP280 barometer driver over I2C (any smbus2-like bus object).

Register map used (datasheet BST-BMP280-DS001, chapter 4): chip id 0xD0 (= 0x58), soft reset
0xE0 (write 0xB6), status 0xF3 (bit 3 measuring, bit 0 im_update), ctrl_meas 0xF4 (osrs_t,
osrs_p, mode), config 0xF5 (t_sb, filter), data 0xF7..0xFC (pressure then temperature, 20 bit,
MSB first, read in one burst so both belong to the same conversion), calibration 0x88..0x9F.
Compensation: see :mod:`sensor.drivers.bmp280_compensation` (double-precision variant).
"""
from __future__ import annotations

import enum
import time
from dataclasses import dataclass
from typing import Any, Callable

from sensor.drivers.bmp280_compensation import (CALIBRATION_BYTES, BMP280Calibration,
                                                compensate_pressure, compensate_temperature)
from sensor.drivers.errors import ChipIdError, DeviceError, DeviceTimeoutError
from sensor.drivers.i2c_registers import I2CRegisters

REG_CALIB = 0x88
REG_CHIP_ID = 0xD0
REG_RESET = 0xE0
REG_STATUS = 0xF3
REG_CTRL_MEAS = 0xF4
REG_CONFIG = 0xF5
REG_DATA = 0xF7  # press_msb, press_lsb, press_xlsb, temp_msb, temp_lsb, temp_xlsb

CHIP_ID = 0x58
RESET_COMMAND = 0xB6
STATUS_MEASURING = 0x08
STATUS_IM_UPDATE = 0x01
SKIPPED_RAW_VALUE = 0x80000  # data register content when a channel is skipped or not yet measured
STARTUP_TIME_S = 0.002  # power-on / soft-reset start-up time (datasheet table 2, t_startup)

_OTHER_CHIPS = {0x60: "a BME280 answers here", 0x56: "a BMP280 engineering sample",
                0x57: "a BMP280 engineering sample", 0x00: "the bus reads zeros (no pull-ups?)",
                0xFF: "the bus reads ones (nothing at this address?)"}


class Oversampling(enum.IntEnum):
    """osrs_p / osrs_t register codes."""

    SKIPPED = 0
    X1 = 1
    X2 = 2
    X4 = 3
    X8 = 4
    X16 = 5

    @property
    def factor(self) -> int:
        """Number of ADC samples averaged (0 when skipped)."""
        return 0 if self == Oversampling.SKIPPED else 1 << (self - 1)


class IIRFilter(enum.IntEnum):
    """config.filter register codes (IIR filter coefficient)."""

    OFF = 0
    X2 = 1
    X4 = 2
    X8 = 3
    X16 = 4

    @property
    def coefficient(self) -> int:
        return 1 if self == IIRFilter.OFF else 1 << self


class PowerMode(enum.IntEnum):
    """ctrl_meas.mode register codes."""

    SLEEP = 0
    FORCED = 1
    NORMAL = 3


class Standby(enum.IntEnum):
    """config.t_sb register codes: inactive time between conversions in normal mode."""

    MS_0_5 = 0
    MS_62_5 = 1
    MS_125 = 2
    MS_250 = 3
    MS_500 = 4
    MS_1000 = 5
    MS_2000 = 6
    MS_4000 = 7

    @property
    def seconds(self) -> float:
        return 0.0005 if self == Standby.MS_0_5 else 0.0625 * (1 << (self - 1))


@dataclass(frozen=True)
class BMP280RegisterSettings:
    """Acquisition settings.

    The default (normal mode, pressure x4, temperature x1, IIR filter off, 0.5 ms standby)
    converts at about 83 Hz with 0.66 Pa resolution; the filter is off so that a contact's
    pressure step shows in full in the next sample.
    """

    pressure_oversampling: Oversampling = Oversampling.X4
    temperature_oversampling: Oversampling = Oversampling.X1
    iir_filter: IIRFilter = IIRFilter.OFF
    standby: Standby = Standby.MS_0_5
    mode: PowerMode = PowerMode.NORMAL

    def __post_init__(self):
        for name, kind in (("pressure_oversampling", Oversampling),
                           ("temperature_oversampling", Oversampling),
                           ("iir_filter", IIRFilter), ("standby", Standby), ("mode", PowerMode)):
            value = getattr(self, name)
            try:
                object.__setattr__(self, name, kind(value))
            except ValueError:
                allowed = ", ".join(member.name for member in kind)
                raise ValueError(f"BMP280RegisterSettings.{name}={value!r} is not one of {allowed}") from None
        if Oversampling.SKIPPED in (self.pressure_oversampling, self.temperature_oversampling):
            raise ValueError("BMP280RegisterSettings: this driver reads both channels; pressure needs the "
                             "temperature (t_fine), so neither oversampling may be SKIPPED")

    def ctrl_meas(self, mode: PowerMode | None = None) -> int:
        """Register 0xF4 value: osrs_t[7:5] osrs_p[4:2] mode[1:0]."""
        mode = self.mode if mode is None else mode
        return (self.temperature_oversampling << 5) | (self.pressure_oversampling << 2) | mode

    def config_register(self) -> int:
        """Register 0xF5 value: t_sb[7:5] filter[4:2] spi3w_en[0] = 0."""
        return (self.standby << 5) | (self.iir_filter << 2)

    def measurement_time_s(self, typical: bool = False) -> float:
        """Duration of one conversion, seconds (datasheet section 3.8.1; maximum by default)."""
        t, p = self.temperature_oversampling.factor, self.pressure_oversampling.factor
        if typical:
            return (1.0 + 2.0 * t + 2.0 * p + 0.5) * 1e-3
        return (1.25 + 2.3 * t + 2.3 * p + 0.575) * 1e-3

    def output_data_rate_hz(self) -> float:
        """Typical conversion rate in normal mode, Hz (datasheet section 3.8.2)."""
        return 1.0 / (self.measurement_time_s(typical=True) + self.standby.seconds)


class BMP280:
    """A BMP280 on an I2C bus.

    The constructor checks the chip id, soft-resets the chip (unless ``reset=False``), waits for
    the NVM copy, reads the calibration and applies ``config``.

    Parameters
    ----------
    bus : smbus2.SMBus-like
        Object with ``read_i2c_block_data``, ``write_byte_data``, ``write_i2c_block_data``.
    address : int
        0x76 (SDO to GND) or 0x77 (SDO to VDDIO).
    config : BMP280RegisterSettings
        Acquisition settings.
    sleep, clock : callable
        ``sleep(seconds)`` and a monotonic ``clock() -> seconds``; injectable for tests.
    attempts : int
        Tries per bus transfer before :class:`~sensor.drivers.errors.BusError`.
    reset : bool
        Soft-reset the chip first.
    """

    def __init__(self, bus: Any, address: int = 0x76, *, config: BMP280RegisterSettings = BMP280RegisterSettings(),
                 sleep: Callable[[float], None] = time.sleep,
                 clock: Callable[[], float] = time.monotonic, attempts: int = 3, reset: bool = True):
        self.registers = I2CRegisters(bus, address, "BMP280", attempts=attempts, sleep=sleep)
        self.sleep = sleep
        self.clock = clock
        self.check_chip_id()
        if reset:
            self.reset()
        else:
            self._wait_until_clear(STATUS_IM_UPDATE, "NVM copy (im_update)", 0.05)
        self.calibration = BMP280Calibration.from_bytes(
            self.registers.read(REG_CALIB, CALIBRATION_BYTES))
        self.config = config
        self.configure(config)

    @property
    def device(self) -> str:
        return self.registers.device

    def check_chip_id(self) -> None:
        """Raise :class:`ChipIdError` unless register 0xD0 reads 0x58."""
        found = self.registers.read_byte(REG_CHIP_ID)
        if found != CHIP_ID:
            raise ChipIdError(self.device, REG_CHIP_ID, found, CHIP_ID, _OTHER_CHIPS.get(found, ""))

    def reset(self) -> None:
        """Soft reset (0xE0 <- 0xB6), then wait until the NVM is copied to the image registers."""
        self.registers.write(REG_RESET, RESET_COMMAND)
        self.sleep(STARTUP_TIME_S)
        self._wait_until_clear(STATUS_IM_UPDATE, "NVM copy (im_update)", 0.05)

    def configure(self, config: BMP280RegisterSettings) -> None:
        """Apply ``config``; the config register is written in sleep mode, where it always takes."""
        if not isinstance(config, BMP280RegisterSettings):
            raise TypeError(f"{self.device}: config must be a BMP280RegisterSettings, got {type(config).__name__}")
        sleep_ctrl = config.ctrl_meas(PowerMode.SLEEP)
        run_ctrl = config.ctrl_meas(PowerMode.SLEEP if config.mode == PowerMode.FORCED else None)
        self.registers.write(REG_CTRL_MEAS, sleep_ctrl)
        self.registers.write(REG_CONFIG, config.config_register())
        self.registers.write(REG_CTRL_MEAS, run_ctrl)
        readback = self.registers.read(REG_CTRL_MEAS, 2)
        if readback != bytes([run_ctrl, config.config_register()]):
            raise DeviceError(self.device, f"configuration not accepted: wrote ctrl_meas/config "
                              f"{run_ctrl:02X} {config.config_register():02X}, read back "
                              f"{readback.hex(' ').upper()}", REG_CTRL_MEAS)
        self.config = config

    def read_raw(self) -> tuple[int, int]:
        """One burst read of 0xF7..0xFC; returns the 20-bit ``(adc_p, adc_t)``.

        In forced mode this first triggers a conversion and waits for it.
        """
        if self.config.mode == PowerMode.FORCED:
            self.registers.write(REG_CTRL_MEAS, self.config.ctrl_meas(PowerMode.FORCED))
            self.sleep(self.config.measurement_time_s())
            self._wait_until_clear(STATUS_MEASURING, "conversion (measuring)",
                                   2 * self.config.measurement_time_s())
        data = self.registers.read(REG_DATA, 6)
        adc_p = (data[0] << 12) | (data[1] << 4) | (data[2] >> 4)
        adc_t = (data[3] << 12) | (data[4] << 4) | (data[5] >> 4)
        return adc_p, adc_t

    def read(self) -> tuple[float, float]:
        """Return ``(pressure_pa, temperature_c)``.

        Waits up to three conversion times if the data registers still hold their reset value
        (just after power-up or configuration); then raises :class:`DeviceTimeoutError`.
        """
        for attempt in range(4):
            adc_p, adc_t = self.read_raw()
            if SKIPPED_RAW_VALUE not in (adc_p, adc_t):
                temperature_c, t_fine = compensate_temperature(adc_t, self.calibration)
                return compensate_pressure(adc_p, t_fine, self.calibration), temperature_c
            if attempt < 3:
                self.sleep(self.config.measurement_time_s())
        raise DeviceTimeoutError(self.device, "no conversion result: data registers keep their "
                                 f"reset value 0x{SKIPPED_RAW_VALUE:05X}", REG_DATA)

    def _wait_until_clear(self, bit: int, what: str, timeout_s: float) -> None:
        deadline = self.clock() + timeout_s
        while self.registers.read_byte(REG_STATUS) & bit:
            if self.clock() > deadline:
                raise DeviceTimeoutError(self.device, f"{what} still busy after "
                                         f"{timeout_s * 1e3:.1f} ms", REG_STATUS)
            self.sleep(0.0005)
