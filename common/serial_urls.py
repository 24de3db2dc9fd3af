"""Registering pyserial URL handlers by package name (``serial.serial_for_url("<scheme>://...")``).

pyserial imports ``<package>.protocol_<scheme>`` when such a URL is opened, so production code can
make an emulator's URLs openable without importing the emulator itself.
"""
from __future__ import annotations


def register_serial_url_package(package: str, needed_for: str) -> None:
    """Let ``serial.serial_for_url`` find the ``protocol_*`` modules of ``package``. Idempotent."""
    try:
        import serial
    except ImportError as error:
        raise ImportError(f"{needed_for} needs pyserial: pip install pyserial (or the project's "
                          "[hardware] extra)") from error
    if package not in serial.protocol_handler_packages:
        serial.protocol_handler_packages.append(package)
