"""Bosch BNO055 register map (page 0) and datasheet constants (BST-BNO055-DS000, chapter 4)."""
from __future__ import annotations

import enum

CHIP_ID_VALUE = 0xA0

CHIP_ID = 0x00
PAGE_ID = 0x07
QUA_DATA = 0x20  # w, x, y, z; int16 LSB first
LIA_DATA = 0x28  # linear acceleration x, y, z
GRV_DATA = 0x2E  # gravity x, y, z
TEMP = 0x34
CALIB_STAT = 0x35
SYS_STATUS = 0x39
SYS_ERR = 0x3A
UNIT_SEL = 0x3B
OPR_MODE = 0x3D
PWR_MODE = 0x3E
SYS_TRIGGER = 0x3F
AXIS_MAP_CONFIG = 0x41
AXIS_MAP_SIGN = 0x42
CALIBRATION_START = 0x55  # ACC_OFFSET_X_LSB .. MAG_RADIUS_MSB (0x6A)
CALIBRATION_LENGTH = 22

REGISTER_NAMES = {
    CHIP_ID: "CHIP_ID", PAGE_ID: "PAGE_ID", QUA_DATA: "QUA_DATA_W_LSB", LIA_DATA: "LIA_DATA_X_LSB",
    GRV_DATA: "GRV_DATA_X_LSB", TEMP: "TEMP", CALIB_STAT: "CALIB_STAT", SYS_STATUS: "SYS_STATUS",
    SYS_ERR: "SYS_ERR", UNIT_SEL: "UNIT_SEL", OPR_MODE: "OPR_MODE", PWR_MODE: "PWR_MODE",
    SYS_TRIGGER: "SYS_TRIGGER", AXIS_MAP_CONFIG: "AXIS_MAP_CONFIG", AXIS_MAP_SIGN: "AXIS_MAP_SIGN",
    CALIBRATION_START: "ACC_OFFSET_X_LSB",
}

SYS_TRIGGER_RESET = 0x20  # RST_SYS bit

QUATERNION_LSB_PER_UNIT = 1 << 14
ACC_LSB_PER_MPS2 = 100.0  # UNIT_SEL acceleration = m/s^2
ACC_LSB_PER_MG = 1.0  # UNIT_SEL acceleration = mg
STANDARD_GRAVITY_MPS2 = 9.80665

CONFIG_TO_OPERATION_S = 0.007  # datasheet table 3-6: CONFIG -> any operation mode
OPERATION_TO_CONFIG_S = 0.019  # any operation mode -> CONFIG
POWER_ON_RESET_S = 0.65  # boot time after reset (datasheet table 0-2, POR time 650 ms)


class OperationMode(enum.IntEnum):
    """OPR_MODE register values (datasheet table 3-5)."""

    CONFIG = 0x00
    ACCONLY = 0x01
    MAGONLY = 0x02
    GYROONLY = 0x03
    ACCMAG = 0x04
    ACCGYRO = 0x05
    MAGGYRO = 0x06
    AMG = 0x07
    IMU = 0x08
    COMPASS = 0x09
    M4G = 0x0A
    NDOF_FMC_OFF = 0x0B
    NDOF = 0x0C

    @property
    def is_fusion(self) -> bool:
        """True for the modes that compute orientation, linear acceleration and gravity."""
        return self >= OperationMode.IMU


def register_label(register: int) -> str:
    """The register's datasheet name (e.g. ``"QUA_DATA_W_LSB"``), or its address in hex."""
    return REGISTER_NAMES.get(register, f"0x{register:02X}")
