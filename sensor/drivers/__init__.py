"""Drivers for the fingertip's chips on real hardware.

* :class:`BMP280` - barometer over I2C (any smbus2-like bus).
* :class:`BNO055I2C`, :class:`BNO055UART` - orientation IMU over I2C or its UART protocol.
* :class:`MicrocontrollerStream` - a microcontroller streaming both chips as text lines
  (protocol in ``mcu_stream_protocol.md``).
* :class:`HardwareTactileSensor` - the :class:`sensor.interface.TactileSensor` built on them.

Nothing here imports smbus2 or pyserial: pass bus and port objects in. Emulators for tests and
dry runs live in :mod:`sensor.emulators`.
"""
from sensor.drivers.bmp280 import BMP280, BMP280RegisterSettings, IIRFilter, Oversampling, PowerMode, Standby
from sensor.drivers.bmp280_compensation import BMP280Calibration
from sensor.drivers.bno055 import BNO055, BNO055I2C
from sensor.drivers.bno055_registers import OperationMode
from sensor.drivers.bno055_types import (AxisRemap, CalibrationProfile, CalibrationStatus,
                                         FusionSample, UnitSelection)
from sensor.drivers.bno055_uart import BNO055UART, UartLinkStats
from sensor.drivers.errors import (BusError, ChipIdError, DeviceDisconnectedError, DeviceError,
                                   DeviceTimeoutError, ProtocolError)
from sensor.drivers.hardware_sensor import ChipSource, HardwareTactileSensor, StreamSource
from sensor.drivers.mcu_stream import MicrocontrollerStream, StreamRecord, StreamStats

__all__ = [
    "BMP280", "BMP280RegisterSettings", "BMP280Calibration", "IIRFilter", "Oversampling", "PowerMode", "Standby",
    "BNO055", "BNO055I2C", "BNO055UART", "OperationMode", "AxisRemap", "CalibrationProfile",
    "CalibrationStatus", "FusionSample", "UnitSelection", "UartLinkStats",
    "MicrocontrollerStream", "StreamRecord", "StreamStats",
    "HardwareTactileSensor", "ChipSource", "StreamSource",
    "DeviceError", "ChipIdError", "BusError", "DeviceTimeoutError", "DeviceDisconnectedError",
    "ProtocolError",
]
