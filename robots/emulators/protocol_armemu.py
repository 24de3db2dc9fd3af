"""pyserial handler for ``armemu://<robot>``: an emulated arm controller on the host's clock.

``<robot>`` is a registered robot name (``armemu://armar3``); the controller gets that robot's
joint limits and starts at its home configuration. ``port.emulator`` is the
:class:`~robots.emulators.arm_serial.FakeArmSerial`, ``port.emulator.controller`` the controller.
"""
from __future__ import annotations

import time
import urllib.parse

from serial.serialutil import SerialException

from robots.emulators.arm_controller import EmulatedArmController
from robots.emulators.arm_serial import FakeArmSerial
from common.pyserial_port import EmulatedSerial


class Serial(EmulatedSerial):
    """The emulated controller behind pyserial's interface; reads never block."""

    scheme = "armemu"

    def emulator_for_url(self, parts: urllib.parse.SplitResult) -> FakeArmSerial:
        if not parts.netloc or parts.path or parts.query:
            raise SerialException(f"expected armemu://<robot name>, e.g. armemu://armar3; got {self._port!r}")
        from robots.registry import load
        try:
            spec = load(parts.netloc)
        except (KeyError, ValueError, FileNotFoundError) as error:
            raise SerialException(f"armemu: {error}") from error
        controller = EmulatedArmController.for_spec(spec, clock=time.monotonic)
        return FakeArmSerial(controller, clock=None, port=self._port)
