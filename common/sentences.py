"""``$<body>*<CS>`` line framing with the NMEA 0183 XOR checksum.

Shared by the microcontroller stream (``sensor.drivers.mcu_stream``) and the robot controller
protocol (``robots.hardware.protocol``). Pure Python, no device access.
"""
from __future__ import annotations


class SentenceError(ValueError):
    """A line that is not a valid sentence; ``kind`` is ``"checksum"`` or ``"malformed"``."""

    def __init__(self, kind: str, message: str):
        super().__init__(message)
        self.kind = kind


def checksum(body: bytes) -> int:
    """XOR of all bytes (the NMEA 0183 checksum)."""
    value = 0
    for byte in body:
        value ^= byte
    return value


def frame(body: str) -> bytes:
    """``$<body>*<CS>\\r\\n``."""
    raw = body.encode("ascii")
    return b"$" + raw + b"*" + f"{checksum(raw):02X}".encode("ascii") + b"\r\n"


def unframe(line: bytes) -> str:
    """The body of one line (newline optional); raises :class:`SentenceError`.

    Noise before the sentence on the same line is ignored: parsing starts at the last ``$``.
    """
    line = line.rstrip(b"\r\n")
    start = line.rfind(b"$")
    if start < 0:
        raise SentenceError("malformed", "no '$' start marker")
    star = line.rfind(b"*")
    if star < start:
        raise SentenceError("malformed", "no '*' checksum marker")
    body, given = line[start + 1:star], line[star + 1:]
    try:
        expected = int(given.decode("ascii"), 16) if len(given) == 2 else -1
    except (UnicodeDecodeError, ValueError):
        expected = -1
    if expected < 0:
        raise SentenceError("malformed", f"checksum field {given!r} is not two hex digits")
    if checksum(body) != expected:
        raise SentenceError("checksum", f"checksum {expected:02X} given, {checksum(body):02X} computed")
    try:
        return body.decode("ascii")
    except UnicodeDecodeError:
        raise SentenceError("malformed", "non-ASCII bytes") from None
