"""pyserial handler for ``bno055emu://``: a BNO055 answering its UART protocol."""
from __future__ import annotations

from sensor.emulators.bno055_serial import FakeBNO055Serial
from common.pyserial_port import EmulatedSerial


class Serial(EmulatedSerial):
    scheme = "bno055emu"

    def make_emulator(self) -> FakeBNO055Serial:
        return FakeBNO055Serial(timeout=self._timeout or 0.0)
