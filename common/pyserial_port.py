"""A pyserial ``SerialBase`` wrapper around an emulated port (imports pyserial)."""
from __future__ import annotations

import urllib.parse

from serial.serialutil import PortNotOpenError, SerialBase, SerialException, to_bytes


class EmulatedSerial(SerialBase):
    """Base for the ``<scheme>://`` handlers; subclasses set ``scheme`` and ``make_emulator``
    (and override ``emulator_for_url`` to read options from the URL)."""

    scheme = ""

    def make_emulator(self):
        raise NotImplementedError

    def emulator_for_url(self, parts: urllib.parse.SplitResult):
        """The emulator for this URL; the default accepts ``<scheme>://`` without options."""
        if parts.netloc or parts.path or parts.query:
            raise SerialException(f"expected the URL {self.scheme}:// (no options), got {self._port!r}")
        return self.make_emulator()

    def open(self) -> None:
        if self.is_open:
            raise SerialException("port is already open")
        if self._port is None:
            raise SerialException("port must be configured before it can be used")
        parts = urllib.parse.urlsplit(self._port)
        if parts.scheme != self.scheme:
            raise SerialException(f"expected a {self.scheme}:// URL, got {self._port!r}")
        self.emulator = self.emulator_for_url(parts)
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
