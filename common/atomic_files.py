"""Files written whole or not at all.

The data goes to a hidden temporary file next to the target, is flushed to disk and renamed over
the target (``os.replace``), so a reader (or a run resumed after a crash or a full disk) finds
either the previous content or the new one, never a truncated file; on failure the temporary file
is removed and the error re-raised.
"""
from __future__ import annotations

import os
from pathlib import Path


def write_bytes_atomically(path: Path, data: bytes) -> Path:
    """Replace ``path`` by ``data`` atomically; returns ``path``."""
    path = Path(path)
    temporary = path.with_name(f".{path.name}.tmp")
    try:
        with open(temporary, "wb") as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(temporary, path)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
    return path
