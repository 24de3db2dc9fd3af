"""The session's ``metadata.json``: what the caller describes plus the fields the format adds."""
from __future__ import annotations

import json
import platform
from datetime import datetime, timezone
from importlib import metadata as package_metadata
from pathlib import Path

from explorer.session.errors import SessionFormatError
from explorer.session.layout import FORMAT_NAME, FORMAT_VERSION, METADATA_FILE
from explorer.session.line_files import write_atomically
from common.plain_json import to_plain

REQUIRED_KEYS = ("robot", "sensor", "object", "seed")
"""Keys the caller's metadata must hold (``seed`` may be None, e.g. for a teleoperated run)."""

FORMAT_KEYS = (
    "format",
    "format_version",
    "start_time_utc",
    "end_time_utc",
    "end_status",
    "end_error",
    "resumed",
    "package_versions",
)
"""Keys the writer fills in; the caller may not use them."""

RECORDED_PACKAGES = (
    "tactile-explore",
    "numpy",
    "scipy",
    "torch",
    "pybullet",
    "pytorch-kinematics",
    "trimesh",
    "scikit-image",
    "smbus2",
    "pyserial",
)


def utc_now() -> str:
    """Current UTC time, ISO 8601 with offset."""
    return datetime.now(timezone.utc).isoformat()


def package_versions() -> dict[str, str | None]:
    """Installed versions of Python and of the packages a run depends on (None: not installed)."""
    versions: dict[str, str | None] = {"python": platform.python_version()}
    for name in RECORDED_PACKAGES:
        try:
            versions[name] = package_metadata.version(name)
        except package_metadata.PackageNotFoundError:
            versions[name] = None
    return versions


def caller_metadata(metadata: dict) -> dict:
    """Validate the caller's run description; return it as plain JSON values."""
    if not isinstance(metadata, dict):
        raise ValueError(f"metadata must be a dict, got {type(metadata).__name__}")
    missing = [key for key in REQUIRED_KEYS if key not in metadata]
    if missing:
        raise ValueError(f"metadata is missing {missing} (required: {list(REQUIRED_KEYS)})")
    reserved = [key for key in FORMAT_KEYS if key in metadata]
    if reserved:
        raise ValueError(f"metadata keys {reserved} are written by the session format itself")
    return to_plain(metadata, "metadata")


def new_metadata(metadata: dict) -> dict:
    """The full ``metadata.json`` content of a session that starts now."""
    return {
        "format": FORMAT_NAME,
        "format_version": FORMAT_VERSION,
        **caller_metadata(metadata),
        "start_time_utc": utc_now(),
        "end_time_utc": None,
        "end_status": "open",
        "end_error": None,
        "resumed": [],
        "package_versions": package_versions(),
    }


def caller_part(stored: dict) -> dict:
    """The caller's run description inside a stored ``metadata.json``."""
    return {key: value for key, value in stored.items() if key not in FORMAT_KEYS}


def save_metadata(directory: Path, metadata: dict) -> None:
    """Write ``metadata.json`` atomically."""
    text = json.dumps(metadata, indent=2, allow_nan=False) + "\n"
    write_atomically(Path(directory) / METADATA_FILE, text.encode("ascii"))


def load_metadata(directory: Path) -> dict:
    """Read and check ``metadata.json`` of a session directory.

    Raises
    ------
    FileNotFoundError
        When the directory holds no ``metadata.json``.
    SessionFormatError
        When it is not JSON, not a session's metadata, or of a format version this code cannot read.
    """
    path = Path(directory) / METADATA_FILE
    if not path.is_file():
        raise FileNotFoundError(f"{directory} is not a session directory: it has no {METADATA_FILE}")
    try:
        stored = json.loads(path.read_text(encoding="utf-8"))
    except ValueError as error:
        raise SessionFormatError(path, None, f"not valid JSON ({error})") from None
    if not isinstance(stored, dict) or stored.get("format") != FORMAT_NAME:
        raise SessionFormatError(path, None, f"not a {FORMAT_NAME} metadata file (field 'format')")
    version = stored.get("format_version")
    if version != FORMAT_VERSION:
        raise SessionFormatError(
            path,
            None,
            f"format_version {version!r} is not supported (this code reads version {FORMAT_VERSION})",
        )
    return stored
