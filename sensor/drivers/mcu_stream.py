"""The microcontroller line protocol: one ASCII line per sample of both chips.

See ``sensor/drivers/mcu_stream_protocol.md`` for the specification. In short::

    $T,<t_ms>,<pressure_pa>,<temp_c>,<qw>,<qx>,<qy>,<qz>,<lax>,<lay>,<laz>,<gx>,<gy>,<gz>*<CS>\\r\\n

``CS`` is two hex digits, the XOR of every byte between ``$`` and ``*``. ``$I,<text>*CS`` lines
carry free-form information. Anything else is counted and skipped; parsing never raises on
input bytes.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from common.sentences import SentenceError, checksum, frame, unframe  # noqa: F401 (checksum re-exported)
from sensor.drivers.device_clock import DeviceClockMapper
from sensor.drivers.errors import DeviceDisconnectedError

DATA_SENTENCE = "T"
INFO_SENTENCE = "I"
DATA_FIELDS = 13  # t_ms, pressure, temperature, 4 quaternion, 3 linear acceleration, 3 gravity
MAX_DEVICE_MS = 1 << 32
PRESSURE_RANGE_PA = (1.0, 200_000.0)
TEMPERATURE_RANGE_C = (-60.0, 125.0)


@dataclass(frozen=True)
class StreamRecord:
    """One ``$T`` sample.

    Attributes
    ----------
    t_device_ms : int
        Microcontroller clock, milliseconds, wraps at 2**32.
    pressure_pa : float
        Compensated barometer pressure, pascals.
    temperature_c : float
        Barometer temperature, degrees Celsius.
    quat_wxyz : (4,) float
        IMU orientation, unit quaternion (normalised on parsing).
    lin_acc_mps2 : (3,) float
        Linear acceleration, sensor frame, m/s^2.
    gravity_mps2 : (3,) float
        Gravity, sensor frame, m/s^2.
    t_host_s : float
        Host monotonic time of the sample (filled in by :class:`MicrocontrollerStream`), seconds.
    """

    t_device_ms: int
    pressure_pa: float
    temperature_c: float
    quat_wxyz: np.ndarray
    lin_acc_mps2: np.ndarray
    gravity_mps2: np.ndarray
    t_host_s: float = float("nan")


class LineError(ValueError):
    """Why a line was rejected; ``kind`` is a :class:`StreamStats` counter name."""

    def __init__(self, kind: str, message: str):
        super().__init__(message)
        self.kind = kind


def encode_record(record: StreamRecord) -> bytes:
    """The line a microcontroller sends for ``record`` (reference encoder for firmware and tests)."""
    values = [f"{record.pressure_pa:.2f}", f"{record.temperature_c:.2f}"]
    values += [f"{v:.5f}" for v in record.quat_wxyz]
    values += [f"{v:.3f}" for v in (*record.lin_acc_mps2, *record.gravity_mps2)]
    return frame_sentence(f"{DATA_SENTENCE},{record.t_device_ms}," + ",".join(values))


def frame_sentence(body: str) -> bytes:
    """``$<body>*<CS>\\r\\n``."""
    return frame(body)


def parse_line(line: bytes) -> StreamRecord | str:
    """Parse one line (without its newline).

    Returns a :class:`StreamRecord` for ``$T`` and the text for ``$I``; raises
    :class:`LineError` with ``kind`` in {"checksum_errors", "malformed", "implausible",
    "unknown_sentences"} otherwise.
    """
    try:
        text = unframe(line)
    except SentenceError as error:
        raise LineError("checksum_errors" if error.kind == "checksum" else "malformed", str(error)) from None
    kind, _, rest = text.partition(",")
    if kind == INFO_SENTENCE:
        return rest
    if kind != DATA_SENTENCE:
        raise LineError("unknown_sentences", f"unknown sentence type {kind!r}")
    return _parse_data(rest.split(","))


def _parse_data(fields: list[str]) -> StreamRecord:
    if len(fields) != DATA_FIELDS:
        raise LineError("malformed", f"$T needs {DATA_FIELDS} fields, got {len(fields)}")
    try:
        t_ms = int(fields[0])
        values = [float(v) for v in fields[1:]]
    except ValueError as exc:
        raise LineError("malformed", f"bad number: {exc}") from None
    if not 0 <= t_ms < MAX_DEVICE_MS:
        raise LineError("malformed", f"t_ms {t_ms} outside 0..2^32-1")
    if not all(math.isfinite(v) for v in values):
        raise LineError("implausible", "non-finite value")
    pressure, temperature = values[0], values[1]
    quaternion = np.array(values[2:6])
    norm = float(np.linalg.norm(quaternion))
    if not PRESSURE_RANGE_PA[0] <= pressure <= PRESSURE_RANGE_PA[1]:
        raise LineError("implausible", f"pressure {pressure} Pa out of range")
    if not TEMPERATURE_RANGE_C[0] <= temperature <= TEMPERATURE_RANGE_C[1]:
        raise LineError("implausible", f"temperature {temperature} C out of range")
    if not 0.9 <= norm <= 1.1:
        raise LineError("implausible", f"quaternion norm {norm:.3f} (fusion not running?)")
    return StreamRecord(t_ms, pressure, temperature, quaternion / norm,
                        np.array(values[6:9]), np.array(values[9:12]))


@dataclass
class StreamStats:
    """What the parser accepted and skipped.

    Attributes
    ----------
    records : int
        ``$T`` lines accepted.
    info_lines : int
        ``$I`` lines received (the last text is in ``last_info``).
    checksum_errors, malformed, implausible, unknown_sentences, oversized : int
        Lines skipped, by reason (oversized: no newline within ``max_line_bytes``).
    device_resets : int
        Times the device clock jumped back (microcontroller restart).
    last_error, last_info : str
    """

    records: int = 0
    info_lines: int = 0
    checksum_errors: int = 0
    malformed: int = 0
    implausible: int = 0
    unknown_sentences: int = 0
    oversized: int = 0
    device_resets: int = 0
    last_error: str = ""
    last_info: str = ""

    @property
    def skipped(self) -> int:
        return (self.checksum_errors + self.malformed + self.implausible + self.unknown_sentences
                + self.oversized)


class MicrocontrollerStream:
    """Reads the line protocol from a serial port.

    Parameters
    ----------
    port : pyserial-like
        ``read(size)``; ``in_waiting`` is used when present. Give it a read timeout.
    clock : callable
        Host monotonic clock, seconds.
    max_line_bytes : int
        Longer lines are dropped (counted as ``oversized``).
    clock_window_s : float
        Window of the device-to-host clock mapping (:class:`DeviceClockMapper`).
    """

    device = "microcontroller stream"

    def __init__(self, port: Any, *, clock: Callable[[], float] = time.monotonic,
                 max_line_bytes: int = 256, clock_window_s: float = 10.0):
        if not callable(getattr(port, "read", None)):
            raise TypeError(f"{self.device}: port object {port!r} lacks read()")
        if max_line_bytes < 64:
            raise ValueError(f"{self.device}: max_line_bytes must be >= 64, got {max_line_bytes}")
        self.port = port
        self.clock = clock
        self.max_line_bytes = max_line_bytes
        self.stats = StreamStats()
        self.clock_mapper = DeviceClockMapper(window_s=clock_window_s)
        self._buffer = bytearray()
        self._discarding = False  # inside an oversized line, until its newline

    def poll(self) -> list[StreamRecord]:
        """Read what the port has (waiting at most its timeout) and return the complete records."""
        try:
            waiting = getattr(self.port, "in_waiting", 0)
            chunk = self.port.read(max(1, waiting))
        except OSError as exc:
            raise DeviceDisconnectedError(self.device, f"port failed: {exc}") from exc
        arrival = self.clock()
        return self.feed(chunk, arrival)

    def feed(self, chunk: bytes, arrival_s: float) -> list[StreamRecord]:
        """Parse bytes received at host time ``arrival_s``; returns the complete records."""
        self._buffer += chunk
        records = []
        while True:
            newline = self._buffer.find(b"\n")
            if newline < 0:
                if len(self._buffer) > self.max_line_bytes:
                    self._reject("oversized", f"no newline within {self.max_line_bytes} bytes",
                                 count=not self._discarding)
                    self._buffer.clear()
                    self._discarding = True
                return records
            line = bytes(self._buffer[:newline])
            del self._buffer[:newline + 1]
            if self._discarding:
                self._discarding = False
                continue
            if len(line) > self.max_line_bytes:
                self._reject("oversized", f"line of {len(line)} bytes")
                continue
            record = self._parse(line, arrival_s)
            if record is not None:
                records.append(record)

    def _parse(self, line: bytes, arrival_s: float) -> StreamRecord | None:
        if not line.strip():
            return None
        try:
            parsed = parse_line(line)
        except LineError as error:
            self._reject(error.kind, str(error))
            return None
        if isinstance(parsed, str):
            self.stats.info_lines += 1
            self.stats.last_info = parsed
            return None
        self.stats.records += 1
        t_host = self.clock_mapper.map(parsed.t_device_ms, arrival_s)
        self.stats.device_resets = self.clock_mapper.device_resets
        return StreamRecord(parsed.t_device_ms, parsed.pressure_pa, parsed.temperature_c,
                            parsed.quat_wxyz, parsed.lin_acc_mps2, parsed.gravity_mps2, t_host)

    def _reject(self, kind: str, message: str, count: bool = True) -> None:
        if count:
            setattr(self.stats, kind, getattr(self.stats, kind) + 1)
        self.stats.last_error = f"{kind}: {message}"
