"""The pyserial surface shared by the emulated serial devices: a receive buffer, read timeouts on
a fake clock, and the error a disconnected or closed port raises."""
from __future__ import annotations


class PortDisconnectedError(OSError):
    """What the emulated port raises once disconnected (pyserial raises SerialException)."""


class FakeSerialPort:
    """Base of the emulated ports; subclasses answer writes and set ``disconnect_fault``.

    Attributes
    ----------
    disconnect_error : exception type
        Raised when the port is used after a disconnect fault or after ``close()``
        (``serial.SerialException`` when opened through pyserial's URL handlers).
    disconnect_fault : enum member or None
        The subclass's fault that means "cable pulled" (read from ``self.faults.permanent``).
    """

    disconnect_error: type[Exception] = PortDisconnectedError
    disconnect_fault = None

    def __init__(self, clock=None, timeout: float = 0.02):
        self.clock = clock
        self.timeout = timeout
        self.is_open = True
        self._to_host = bytearray()

    @property
    def in_waiting(self) -> int:
        self._check_connected()
        return len(self._to_host)

    def read(self, size: int = 1) -> bytes:
        """Up to ``size`` bytes; a short read costs the timeout on the fake clock."""
        self._check_connected()
        data = bytes(self._to_host[:size])
        del self._to_host[:size]
        if len(data) < size and self.clock is not None:
            self.clock.advance(self.timeout)
        return data

    def queue_bytes(self, data: bytes) -> None:
        """Put raw bytes in the receive buffer (a boot banner, noise, corrupted lines)."""
        self._to_host += bytes(data)

    def reset_input_buffer(self) -> None:
        self._check_connected()
        self._to_host.clear()

    def reset_output_buffer(self) -> None:
        self._check_connected()

    def flush(self) -> None:
        self._check_connected()

    def close(self) -> None:
        self.is_open = False

    def _check_connected(self) -> None:
        if self.disconnect_fault is not None and self.faults.permanent is self.disconnect_fault:
            raise self.disconnect_error("device reports readiness to read but returned no data "
                                        "(device disconnected or multiple access on port?)")
        if not self.is_open:
            raise self.disconnect_error("port is closed")
