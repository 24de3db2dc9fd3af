"""Emulators that behave like the fingertip's chips at register and byte level.

They let the drivers in :mod:`sensor.drivers` be tested (and the exploration loop be dry-run)
without hardware, with injectable faults:

* :class:`FakeSMBus` with :class:`BMP280Chip` and :class:`BNO055Chip` attached;
* :class:`FakeBNO055Serial`, a port speaking the BNO055 UART protocol;
* :class:`FakeMicrocontrollerSerial`, a port streaming the ``$T`` line protocol;
* :func:`register_serial_url_handlers` for ``serial.serial_for_url("bno055emu://")`` and
  ``"mcuemu://"`` (needs pyserial; nothing else here does);
* :class:`FakeClock`, so that drivers' waits cost no real time.
"""
from sensor.emulators.bmp280_chip import BMP280Chip
from sensor.emulators.bno055_chip import BNO055Chip
from sensor.emulators.bno055_serial import FakeBNO055Serial
from common.fake_port import FakeSerialPort, PortDisconnectedError
from common.clock import FakeClock
from sensor.emulators.fake_smbus import FakeSMBus
from sensor.emulators.faults import Fault, FaultInjector
from sensor.emulators.mcu_serial import FakeMicrocontrollerSerial
from sensor.emulators.serial_urls import register_serial_url_handlers

__all__ = ["BMP280Chip", "BNO055Chip", "FakeSMBus", "FakeBNO055Serial", "FakeMicrocontrollerSerial",
           "FakeClock", "FakeSerialPort", "Fault", "FaultInjector", "PortDisconnectedError",
           "register_serial_url_handlers"]
