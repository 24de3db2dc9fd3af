"""Append-only line files: one record per line, a record counts only once its newline is written.

Writes go straight to the file descriptor (one ``os.write`` per record, no user-space buffer), so a
record handed to :meth:`AppendOnlyFile.append` is in the kernel's page cache when the call returns and
survives the process being killed. ``fsync=True`` additionally forces it to the disk (survives power
loss), at the price of a disk round trip per record.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from common.atomic_files import write_bytes_atomically


@dataclass(frozen=True)
class CompleteLines:
    """The complete lines of a line file.

    Attributes
    ----------
    lines : list of str
        Every line that ends in ``\\n``, without the newline, in file order (line 1 first).
    partial_tail_bytes : int
        Bytes after the last newline: a record cut off by a crash (0 when the file ends cleanly).
    """

    lines: list[str]
    partial_tail_bytes: int


def read_complete_lines(path: Path) -> CompleteLines:
    """Read ``path`` up to its last newline; a missing file reads as empty."""
    try:
        data = Path(path).read_bytes()
    except FileNotFoundError:
        return CompleteLines([], 0)
    end = data.rfind(b"\n") + 1
    text = data[:end].decode("utf-8", errors="strict")
    return CompleteLines(text.split("\n")[:-1], len(data) - end)


def partial_tail_bytes(path: Path) -> int:
    """Number of bytes after the last newline of ``path`` (0 for a clean or missing file)."""
    try:
        with open(path, "rb") as handle:
            size = handle.seek(0, os.SEEK_END)
            position = size
            while position > 0:
                step = min(4096, position)
                handle.seek(position - step)
                block = handle.read(step)
                newline = block.rfind(b"\n")
                if newline >= 0:
                    return size - (position - step + newline + 1)
                position -= step
            return size
    except FileNotFoundError:
        return 0


def cut_partial_tail(path: Path) -> int:
    """Remove the bytes after the last newline of ``path``; return how many were removed."""
    tail = partial_tail_bytes(path)
    if tail:
        with open(path, "r+b") as handle:
            handle.truncate(handle.seek(0, os.SEEK_END) - tail)
            handle.flush()
            os.fsync(handle.fileno())
    return tail


def fsync_directory(directory: Path) -> None:
    """Make a file creation or rename inside ``directory`` durable (no-op where unsupported)."""
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def write_atomically(path: Path, data: bytes) -> None:
    """Replace ``path`` by ``data`` whole (:func:`common.atomic_files.write_bytes_atomically`), then
    make the rename itself durable."""
    write_bytes_atomically(path, data)
    fsync_directory(Path(path).parent)


class AppendOnlyFile:
    """A file that only ever grows by whole lines.

    Parameters
    ----------
    path : Path
        Created when missing; existing content is kept and appended to.
    """

    def __init__(self, path: Path):
        self.path = Path(path)
        self._fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)

    def size(self) -> int:
        """Current size of the file, bytes."""
        return os.fstat(self._fd).st_size

    def append(self, line: str, fsync: bool = False) -> None:
        """Append ``line`` (which must not contain a newline) followed by ``\\n``."""
        data = memoryview((line + "\n").encode("utf-8"))
        while data:
            written = os.write(self._fd, data)
            data = data[written:]
        if fsync:
            os.fsync(self._fd)

    def fsync(self) -> None:
        """Force everything appended so far to the disk."""
        os.fsync(self._fd)

    def close(self) -> None:
        """Close the descriptor. Idempotent."""
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1
