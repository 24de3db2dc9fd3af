"""pyserial URL handlers for the emulated ports.

After :func:`register_serial_url_handlers`::

    imu_port = serial.serial_for_url("bno055emu://", timeout=0.02)   # BNO055 UART emulator
    mcu_port = serial.serial_for_url("mcuemu://", timeout=0.02)      # line-stream emulator

``imu_port.emulator`` is the :class:`~sensor.emulators.bno055_serial.FakeBNO055Serial` behind
it (``imu_port.emulator.chip`` the chip), ``mcu_port.emulator`` the
:class:`~sensor.emulators.mcu_serial.FakeMicrocontrollerSerial`. Reads never block: a short read
returns at once, as if the timeout had passed.
"""
from __future__ import annotations

from common.serial_urls import register_serial_url_package

PACKAGE = "sensor.emulators"


def register_serial_url_handlers() -> None:
    """Let ``serial.serial_for_url`` open ``bno055emu://`` and ``mcuemu://``. Idempotent."""
    register_serial_url_package(PACKAGE, "the emulator URLs")
