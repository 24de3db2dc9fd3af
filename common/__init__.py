"""What both ``robots`` and ``sensor`` need, and nothing of theirs: the bottom layer.

* :mod:`common.rotations` - (w, x, y, z) quaternions, rotation matrices, scipy bridge;
* :mod:`common.directions` - evenly spread unit directions, perpendicular frames;
* :mod:`common.pad_state` - the simulator's true pad state (robots produce it, sensors read it);
* :mod:`common.sentences` - ``$...*CS`` line framing of the serial protocols;
* :mod:`common.clock`, :mod:`common.fake_port`, :mod:`common.pyserial_port` - a virtual clock and
  in-memory serial ports for the emulators; :mod:`common.serial_urls` - pyserial URL handlers;
* :mod:`common.plain_json` - numpy values as plain JSON; :mod:`common.lazy_exports` - package roots that import on first use;
* :mod:`common.atomic_files` - files written whole or not at all.
"""
from common.atomic_files import write_bytes_atomically
from common.clock import FakeClock
from common.pad_state import PadState

__all__ = ["FakeClock", "PadState", "write_bytes_atomically"]
