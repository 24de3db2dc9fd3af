"""pyserial handler for ``mcuemu://``: a microcontroller streaming the ``$T`` line protocol."""
from __future__ import annotations

from sensor.emulators.mcu_serial import FakeMicrocontrollerSerial
from common.pyserial_port import EmulatedSerial


class Serial(EmulatedSerial):
    scheme = "mcuemu"

    def make_emulator(self) -> FakeMicrocontrollerSerial:
        return FakeMicrocontrollerSerial(timeout=self._timeout or 0.0)
