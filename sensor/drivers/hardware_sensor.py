"""The fingertip sensor on real hardware, behind :class:`sensor.interface.TactileSensor`.

Two sources of readings:

* :class:`ChipSource` polls a :class:`~sensor.drivers.bmp280.BMP280` and a BNO055 (I2C or
  UART) directly, one reading per poll, stamped with the host clock at the middle of the
  transfers.
* :class:`StreamSource` decodes a :class:`~sensor.drivers.mcu_stream.MicrocontrollerStream`,
  stamped with the microcontroller's clock mapped onto the host clock.

:class:`HardwareTactileSensor` polls its source either when asked (``read``/``drain``) or, with
``background=True``, from a reader thread that starts in :meth:`open` and stops in
:meth:`close`; an error that stops that thread is raised by every later ``read``/``drain``.
"""
from __future__ import annotations

import threading
import time
from collections import deque
from typing import Callable, Protocol

from sensor.drivers.bmp280 import BMP280
from sensor.drivers.bno055 import BNO055
from sensor.drivers.bno055_registers import OperationMode
from sensor.drivers.errors import DeviceTimeoutError
from sensor.drivers.mcu_stream import MicrocontrollerStream
from sensor.interface import TactileSensor
from sensor.reading import Reading


class ReadingSource(Protocol):
    """Where readings come from."""

    device: str

    def open(self) -> None: ...

    def close(self) -> None: ...

    def poll(self) -> list[Reading]:
        """Readings produced since the previous poll (possibly none), oldest first."""


class ChipSource:
    """Polls the two chips.

    Parameters
    ----------
    barometer : BMP280
    imu : BNO055
        Either transport.
    imu_mode : OperationMode or None
        Fusion mode set in :meth:`open` (None leaves the chip as it is). NDOF gives an absolute
        heading; IMU mode avoids the magnetometer near motors but its heading drifts.
    clock : callable
        Host monotonic clock, seconds.
    """

    def __init__(self, barometer: BMP280, imu: BNO055, *,
                 imu_mode: OperationMode | None = OperationMode.NDOF,
                 clock: Callable[[], float] = time.monotonic):
        if imu_mode is not None and not OperationMode(imu_mode).is_fusion:
            raise ValueError(f"imu_mode must be a fusion mode, got {OperationMode(imu_mode).name}")
        self.barometer = barometer
        self.imu = imu
        self.imu_mode = imu_mode
        self.clock = clock
        self.device = f"{barometer.device} + {imu.device}"

    def open(self) -> None:
        if self.imu_mode is not None:
            self.imu.set_mode(self.imu_mode)

    def close(self) -> None:
        """The chips keep running; the buses belong to the caller."""

    def poll(self) -> list[Reading]:
        start = self.clock()
        pressure_pa, temperature_c = self.barometer.read()
        fusion = self.imu.fusion_sample()
        t_s = 0.5 * (start + self.clock())
        return [Reading(t_s=t_s, pressure_pa=pressure_pa, quat_wxyz=fusion.quat_wxyz,
                        lin_acc_mps2=fusion.lin_acc_mps2, gravity_mps2=fusion.gravity_mps2,
                        temperature_c=temperature_c)]


class StreamSource:
    """Decodes the microcontroller line stream."""

    def __init__(self, stream: MicrocontrollerStream):
        self.stream = stream
        self.device = stream.device

    def open(self) -> None:
        reset = getattr(self.stream.port, "reset_input_buffer", None)
        if callable(reset):
            reset()  # drop what piled up while nobody listened

    def close(self) -> None:
        """The port belongs to the caller."""

    def poll(self) -> list[Reading]:
        return [Reading(t_s=r.t_host_s, pressure_pa=r.pressure_pa, quat_wxyz=r.quat_wxyz,
                        lin_acc_mps2=r.lin_acc_mps2, gravity_mps2=r.gravity_mps2,
                        temperature_c=r.temperature_c)
                for r in self.stream.poll()]


class HardwareTactileSensor(TactileSensor):
    """TactileSensor over real chips or a microcontroller stream.

    Parameters
    ----------
    source : ReadingSource
        :class:`ChipSource` or :class:`StreamSource` (or see :meth:`from_chips`,
        :meth:`from_stream`).
    background : bool
        Poll from a reader thread (started in :meth:`open`) instead of inside read/drain. Use
        it for a stream, whose port buffer would otherwise overflow between calls.
    poll_period_s : float
        Minimum time between background polls, seconds.
    max_buffered : int
        Readings kept for :meth:`drain`; older ones are dropped and counted in ``dropped``.
    read_timeout_s : float
        How long :meth:`read` waits for a first reading.
    clock, sleep : callable
        Host monotonic clock and sleep, for :meth:`read`'s wait.
    """

    def __init__(self, source: ReadingSource, *, background: bool = False,
                 poll_period_s: float = 0.002, max_buffered: int = 100_000,
                 read_timeout_s: float = 1.0, clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep):
        if max_buffered < 1:
            raise ValueError(f"max_buffered must be >= 1, got {max_buffered}")
        if poll_period_s < 0:
            raise ValueError(f"poll_period_s must be >= 0, got {poll_period_s}")
        self.source = source
        self.background = background
        self.poll_period_s = poll_period_s
        self.read_timeout_s = read_timeout_s
        self.clock = clock
        self.sleep = sleep
        self.dropped = 0
        self._buffer: deque[Reading] = deque(maxlen=max_buffered)
        self._newest: Reading | None = None
        self._lock = threading.Lock()
        self._is_open = False
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._thread_error: BaseException | None = None

    @classmethod
    def from_chips(cls, barometer: BMP280, imu: BNO055, *,
                   imu_mode: OperationMode | None = OperationMode.NDOF,
                   clock: Callable[[], float] = time.monotonic, **options) -> "HardwareTactileSensor":
        return cls(ChipSource(barometer, imu, imu_mode=imu_mode, clock=clock), clock=clock, **options)

    @classmethod
    def from_stream(cls, stream: MicrocontrollerStream, **options) -> "HardwareTactileSensor":
        options.setdefault("background", True)
        options.setdefault("clock", stream.clock)
        return cls(StreamSource(stream), **options)

    @property
    def is_open(self) -> bool:
        return self._is_open

    def open(self) -> None:
        if self._is_open:
            return
        self.source.open()
        self._is_open = True
        self._thread_error = None
        if self.background:
            self._stop.clear()
            self._thread = threading.Thread(target=self._run, name=f"reader: {self.source.device}",
                                            daemon=True)
            self._thread.start()

    def close(self) -> None:
        if not self._is_open:
            return
        if self._thread is not None:
            self._stop.set()
            self._thread.join()
            self._thread = None
        self._is_open = False
        self.source.close()

    def read(self) -> Reading:
        """The newest reading; waits up to ``read_timeout_s`` for the first one."""
        deadline = self.clock() + self.read_timeout_s
        while True:
            self._collect()
            if self._newest is not None:
                return self._newest
            if self.clock() > deadline:
                raise DeviceTimeoutError(self.source.device, f"no reading within {self.read_timeout_s} s")
            self.sleep(0.001)

    def drain(self) -> list[Reading]:
        """Every reading since the previous drain, oldest first."""
        self._collect()
        with self._lock:
            readings = list(self._buffer)
            self._buffer.clear()
        return readings

    def _collect(self) -> None:
        if not self._is_open:
            raise RuntimeError(f"{self.source.device}: sensor is not open; call open() or use 'with'")
        if self._thread_error is not None:
            raise self._thread_error  # the reader thread stopped; raised until close()
        if not self.background:
            self._store(self.source.poll())

    def _store(self, readings: list[Reading]) -> None:
        if not readings:
            return
        with self._lock:
            overflow = len(self._buffer) + len(readings) - self._buffer.maxlen
            if overflow > 0:
                self.dropped += overflow
            self._buffer.extend(readings)
            self._newest = readings[-1]

    def _run(self) -> None:
        while not self._stop.is_set():
            started = time.monotonic()
            try:
                self._store(self.source.poll())
            except BaseException as error:  # handed to the caller's thread
                self._thread_error = error
                return
            remaining = self.poll_period_s - (time.monotonic() - started)
            if remaining > 0:
                self._stop.wait(remaining)
