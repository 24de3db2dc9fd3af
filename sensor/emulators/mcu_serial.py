"""A serial-port stand-in for a microcontroller that streams the ``$T`` line protocol."""
from __future__ import annotations

import numpy as np

from sensor.drivers.mcu_stream import StreamRecord, encode_record, frame_sentence
from common.fake_port import FakeSerialPort
from common.clock import FakeClock
from sensor.emulators.faults import Fault, FaultInjector


class FakeMicrocontrollerSerial(FakeSerialPort):
    """pyserial-like port whose input is whatever the test queues.

    Parameters
    ----------
    clock : FakeClock or None
        Advanced by ``timeout`` when a read finds fewer bytes than asked for.
    timeout : float
        Read timeout the port pretends to have, seconds.

    Attributes
    ----------
    faults : FaultInjector
        DISCONNECT (reads raise from now on) and SILENT (reads return nothing from now on);
        checked once per read.
    """

    disconnect_fault = Fault.DISCONNECT

    def __init__(self, *, clock: FakeClock | None = None, timeout: float = 0.02):
        super().__init__(clock, timeout)
        self.faults = FaultInjector()

    def queue_sample(self, t_ms: int, pressure_pa: float = 101325.0, temperature_c: float = 25.0,
                     quat_wxyz=(1.0, 0.0, 0.0, 0.0), lin_acc_mps2=(0.0, 0.0, 0.0),
                     gravity_mps2=(0.0, 0.0, 9.80665)) -> bytes:
        """Queue one ``$T`` line; returns it."""
        line = encode_record(StreamRecord(t_ms, pressure_pa, temperature_c, np.asarray(quat_wxyz, float),
                                          np.asarray(lin_acc_mps2, float), np.asarray(gravity_mps2, float)))
        self._to_host += line
        return line

    def queue_info(self, text: str) -> None:
        self._to_host += frame_sentence(f"I,{text}")

    @property
    def in_waiting(self) -> int:
        self._check_connected()
        return 0 if self.faults.permanent is Fault.SILENT else len(self._to_host)

    def read(self, size: int = 1) -> bytes:
        fault = self.faults.take(None)
        if fault is not None and fault not in (Fault.DISCONNECT, Fault.SILENT):
            raise ValueError(f"fault {fault.name} does not apply to the line stream")
        self._check_connected()
        if fault is Fault.SILENT:
            data = b""
        else:
            data = bytes(self._to_host[:size])
            del self._to_host[:size]
        if len(data) < size and self.clock is not None:
            self.clock.advance(self.timeout)
        return data

    def write(self, data: bytes) -> int:
        self._check_connected()
        return len(data)

