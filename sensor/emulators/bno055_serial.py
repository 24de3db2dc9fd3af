"""A serial-port stand-in that speaks the BNO055 UART protocol (datasheet section 4.7)."""
from __future__ import annotations

from sensor.emulators.bno055_chip import BNO055Chip
from common.clock import FakeClock
from sensor.emulators.fake_smbus import ChipBusy
from common.fake_port import FakeSerialPort
from sensor.emulators.faults import Fault, FaultInjector

#: Noise injected by Fault.GARBAGE; it contains both reply headers (0xBB, 0xEE) followed by
#: bytes that cannot continue a valid reply, to exercise resynchronisation.
DEFAULT_GARBAGE = bytes([0x00, 0xBB, 0x7F, 0xEE, 0x99, 0x55, 0xFF, 0xEE])


class FakeBNO055Serial(FakeSerialPort):
    """pyserial-like port with a BNO055 behind it.

    Each complete request frame written is answered at once into the receive buffer. A read
    returns what is buffered, up to ``size`` bytes; when that is short, a real port would have
    blocked for ``timeout`` seconds, so the optional :class:`FakeClock` is advanced by it.

    Parameters
    ----------
    chip : BNO055Chip
    clock : FakeClock or None
    timeout : float
        Read timeout the port pretends to have, seconds.
    garbage : bytes
        Noise used by :attr:`Fault.GARBAGE`.

    Attributes
    ----------
    faults : FaultInjector
        Per-request faults (NO_REPLY, OVERRUN, FAIL_STATUS, INVALID_ADDRESS, TRUNCATED, GARBAGE,
        DISCONNECT, SILENT).
    requests : list of bytes
        Every complete request frame received.
    """

    disconnect_fault = Fault.DISCONNECT

    def __init__(self, chip: BNO055Chip | None = None, *, clock: FakeClock | None = None,
                 timeout: float = 0.02, garbage: bytes = DEFAULT_GARBAGE):
        super().__init__(clock, timeout)
        self.chip = chip if chip is not None else BNO055Chip(clock=clock.monotonic if clock else None)
        self.garbage = garbage
        self.faults = FaultInjector()
        self.requests: list[bytes] = []
        self._from_host = bytearray()

    # -- pyserial surface -------------------------------------------------------------------

    def write(self, data: bytes) -> int:
        self._check_connected()
        self._from_host += bytes(data)
        self._process()
        return len(data)

    # -- protocol ---------------------------------------------------------------------------

    def _process(self) -> None:
        while self._from_host:
            if self._from_host[0] != 0xAA:
                del self._from_host[0]
                self._to_host += bytes([0xEE, 0x06])  # WRONG_START_BYTE
                continue
            if len(self._from_host) < 4:
                return
            command, register, length = self._from_host[1:4]
            frame_length = 4 + (length if command == 0x00 else 0)
            if command not in (0x00, 0x01):
                self._from_host.clear()
                self._to_host += bytes([0xEE, 0x06])
                return
            if len(self._from_host) < frame_length:
                return
            frame = bytes(self._from_host[:frame_length])
            del self._from_host[:frame_length]
            self.requests.append(frame)
            self._answer(frame)

    def _answer(self, frame: bytes) -> None:
        command, register, length = frame[1:4]
        fault = self.faults.take(register)
        if fault is Fault.DISCONNECT:
            self._check_connected()
        if fault in (Fault.NO_REPLY, Fault.SILENT):
            return
        if fault is Fault.OVERRUN:
            self._to_host += bytes([0xEE, 0x07])
            return
        if fault is Fault.FAIL_STATUS:
            self._to_host += bytes([0xEE, 0x02 if command == 0x01 else 0x03])
            return
        if fault is Fault.INVALID_ADDRESS:
            self._to_host += bytes([0xEE, 0x04])
            return
        if fault is not None and fault not in (Fault.TRUNCATED, Fault.GARBAGE):
            raise ValueError(f"fault {fault.name} does not apply to a UART port")
        reply = self._execute(command, register, length, frame[4:])
        if reply is None:
            return
        if fault is Fault.TRUNCATED:
            reply = reply[:max(1, len(reply) // 2)]
        if fault is Fault.GARBAGE:
            reply = self.garbage + reply
        self._to_host += reply

    def _execute(self, command: int, register: int, length: int, payload: bytes) -> bytes | None:
        if length == 0:
            return bytes([0xEE, 0x09])  # MIN_LENGTH_ERROR
        if length > 128:
            return bytes([0xEE, 0x08])  # MAX_LENGTH_ERROR
        try:
            if command == 0x01:
                if register + length > 0x80:
                    return bytes([0xEE, 0x04])
                return bytes([0xBB, length]) + self.chip.read_block(register, length)
            result = self.chip.write_block(register, payload)
        except ChipBusy:
            return None  # the chip does not answer while it switches mode or boots
        return bytes([0xEE, int(result)])
