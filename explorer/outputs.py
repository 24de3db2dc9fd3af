"""Output files written whole or not at all.

Each file is written to a hidden temporary file next to it, flushed to disk and renamed over the
target (``os.replace``), so a reader (or a run resumed after a crash or a full disk) finds either
the previous content or the new one, never a truncated file; on failure the temporary file is
removed and the error re-raised.
"""
from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any


def write_bytes(path: Path, data: bytes) -> Path:
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


def write_text(path: Path, text: str) -> Path:
    """Replace ``path`` by ``text`` (UTF-8) atomically."""
    return write_bytes(path, text.encode("utf-8"))


def write_json(path: Path, data: Any) -> Path:
    """Replace ``path`` by ``data`` as indented JSON, atomically (``data`` must be JSON-ready)."""
    return write_text(path, json.dumps(data, indent=2))


def export_mesh(mesh, path: Path) -> Path:
    """Write a trimesh mesh to ``path`` (format from the suffix, e.g. ``.ply``) atomically."""
    path = Path(path)
    return write_bytes(path, mesh.export(file_type=path.suffix.lstrip(".").lower()))
