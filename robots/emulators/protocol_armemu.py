"""pyserial handler for ``armemu://<robot>``: an emulated arm controller on the host's clock.

``<robot>`` is a registered robot name (``armemu://armar3``); the controller gets that robot's
joint limits and starts at its home configuration. ``port.emulator`` is the
:class:`~robots.emulators.arm_serial.FakeArmSerial`, ``port.emulator.controller`` the controller.
"""
from __future__ import annotations

import time
import urllib.parse

from serial.serialutil import PortNotOpenError, SerialBase, SerialException, to_bytes

from robots.emulators.arm_controller import EmulatedArmController
from robots.emulators.arm_serial import FakeArmSerial


class Serial(SerialBase):
    """The emulated controller behind pyserial's interface; reads never block."""

    def open(self) -> None:
        if self.is_open:
            raise SerialException("port is already open")
        if self._port is None:
            raise SerialException("port must be configured before it can be used")
        parts = urllib.parse.urlsplit(self._port)
        if parts.scheme != "armemu" or not parts.netloc or parts.path or parts.query:
            raise SerialException(f"expected armemu://<robot name>, e.g. armemu://armar3; got {self._port!r}")
        from robots.registry import load
        try:
            spec = load(parts.netloc)
        except (KeyError, ValueError, FileNotFoundError) as error:
            raise SerialException(f"armemu: {error}") from error
        controller = EmulatedArmController.for_spec(spec, clock=time.monotonic)
        self.emulator = FakeArmSerial(controller, clock=None, port=self._port)
        self.emulator.disconnect_error = SerialException
        self.is_open = True

    def close(self) -> None:
        if self.is_open:
            self.emulator.close()
        self.is_open = False

    def _reconfigure_port(self, *args, **kwargs) -> None:
        """Line settings mean nothing to an emulator."""

    def _update_rts_state(self) -> None:
        pass

    def _update_dtr_state(self) -> None:
        pass

    def _update_break_state(self) -> None:
        pass

    @property
    def in_waiting(self) -> int:
        self._require_open()
        return self.emulator.in_waiting

    def read(self, size: int = 1) -> bytes:
        self._require_open()
        return self.emulator.read(size)

    def write(self, data) -> int:
        self._require_open()
        return self.emulator.write(to_bytes(data))

    def reset_input_buffer(self) -> None:
        self._require_open()
        self.emulator.reset_input_buffer()

    def reset_output_buffer(self) -> None:
        self._require_open()

    def flush(self) -> None:
        self._require_open()

    def _require_open(self) -> None:
        if not self.is_open:
            raise PortNotOpenError()
