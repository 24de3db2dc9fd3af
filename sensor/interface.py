"""The sensor interface the exploration loop depends on (simulation and hardware alike)."""
from __future__ import annotations

import abc

from sensor.reading import Reading


class TactileSensor(abc.ABC):
    """A fingertip sensor that yields timestamped :class:`Reading` records.

    Use it as a context manager so that hardware is opened and released explicitly::

        with sensor:
            for reading in sensor.drain():
                ...
    """

    def open(self) -> None:
        """Acquire the device (bus, port, simulator hook). Idempotent."""

    def close(self) -> None:
        """Release the device. Idempotent."""

    def __enter__(self) -> "TactileSensor":
        self.open()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @abc.abstractmethod
    def read(self) -> Reading:
        """Return the newest reading."""

    @abc.abstractmethod
    def drain(self) -> list[Reading]:
        """Return every reading produced since the previous call, oldest first."""
