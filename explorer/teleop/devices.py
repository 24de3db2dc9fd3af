"""Input devices for teleoperation behind one small interface: a Cartesian pad velocity plus buttons.

Devices never touch the simulator: the keyboard device is handed a callable that returns the
GUI's key events (the sim glue supplies it), and drawing happens elsewhere.
"""
from __future__ import annotations

import abc
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Mapping, Sequence

import numpy as np

#: Buttons a device may report.
BUTTONS = frozenset({"record", "quit"})


def _vector3(value, name: str) -> np.ndarray:
    vector = np.asarray(value, dtype=float)
    if vector.shape != (3,) or not np.all(np.isfinite(vector)):
        raise ValueError(f"{name} must be 3 finite numbers, got {value!r}")
    return vector


@dataclass(frozen=True)
class TeleopCommand:
    """What the operator asks for now.

    Attributes
    ----------
    linear_mps : (3,) float
        Pad velocity, world frame, m/s.
    angular_radps : (3,) float
        Pad angular velocity, world frame, rad/s.
    buttons : frozenset of str
        Buttons pressed since the last poll, from :data:`BUTTONS`.
    """

    linear_mps: np.ndarray = field(default_factory=lambda: np.zeros(3))
    angular_radps: np.ndarray = field(default_factory=lambda: np.zeros(3))
    buttons: frozenset = frozenset()

    def __post_init__(self):
        object.__setattr__(self, "linear_mps", _vector3(self.linear_mps, "linear_mps"))
        object.__setattr__(self, "angular_radps", _vector3(self.angular_radps, "angular_radps"))
        unknown = set(self.buttons) - BUTTONS
        if unknown:
            raise ValueError(f"unknown buttons {sorted(unknown)}; known: {sorted(BUTTONS)}")
        object.__setattr__(self, "buttons", frozenset(self.buttons))

    @property
    def is_still(self) -> bool:
        """No motion asked for."""
        return not (np.any(self.linear_mps) or np.any(self.angular_radps))


class InputDevice(abc.ABC):
    """A source of :class:`TeleopCommand`; open it (or use it as a context manager) before polling."""

    def __init__(self):
        self.is_open = False

    def open(self) -> None:
        """Acquire the device. Idempotent."""
        self.is_open = True

    def close(self) -> None:
        """Release the device. Idempotent."""
        self.is_open = False

    def __enter__(self) -> "InputDevice":
        self.open()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def poll(self) -> TeleopCommand:
        """The current command."""
        if not self.is_open:
            raise RuntimeError(f"{type(self).__name__} is not open: call open() or use it as a context manager")
        return self._poll()

    @abc.abstractmethod
    def _poll(self) -> TeleopCommand:
        """The current command (the device is open)."""


# PyBullet's key codes and key-state flags (pybullet.B3G_*, KEY_IS_DOWN, KEY_WAS_TRIGGERED).
KEY_LEFT, KEY_RIGHT, KEY_UP, KEY_DOWN = 65295, 65296, 65297, 65298
KEY_PAGE_UP, KEY_PAGE_DOWN = 65299, 65300
KEY_IS_DOWN, KEY_WAS_TRIGGERED = 1, 2


class KeyboardDevice(InputDevice):
    """Jogging with the keys of the PyBullet window.

    Arrows move the pad along world -x/+x (left/right) and +y/-y (up/down), page up/down along
    +z/-z, at ``speed_mps`` while held; ``r`` records a reconstruction snapshot, ``q`` quits.

    Parameters
    ----------
    key_events : callable () -> mapping {key code: state flags}
        The GUI's keyboard events since the last call (``pybullet.getKeyboardEvents`` of the
        sim's client, wrapped by the sim glue).
    speed_mps : float
    """

    AXES = {KEY_LEFT: (0, -1.0), KEY_RIGHT: (0, 1.0), KEY_UP: (1, 1.0), KEY_DOWN: (1, -1.0),
            KEY_PAGE_UP: (2, 1.0), KEY_PAGE_DOWN: (2, -1.0)}
    BUTTON_KEYS = {ord("r"): "record", ord("q"): "quit"}

    def __init__(self, key_events: Callable[[], Mapping[int, int]], speed_mps: float = 0.01):
        super().__init__()
        if not callable(key_events):
            raise ValueError("key_events must be a callable returning {key code: state flags}")
        if not speed_mps > 0:
            raise ValueError(f"speed_mps must be > 0, got {speed_mps}")
        self._events = key_events
        self.speed_mps = float(speed_mps)

    def _poll(self) -> TeleopCommand:
        events = self._events()
        velocity = np.zeros(3)
        buttons = set()
        for key, state in events.items():
            if key in self.AXES and state & KEY_IS_DOWN:
                axis, sign = self.AXES[key]
                velocity[axis] += sign * self.speed_mps
            elif key in self.BUTTON_KEYS and state & KEY_WAS_TRIGGERED:
                buttons.add(self.BUTTON_KEYS[key])
        return TeleopCommand(velocity, np.zeros(3), frozenset(buttons))


class SpaceMouseDevice(InputDevice):
    """A 3Dconnexion SpaceMouse through the optional ``pyspacemouse`` package.

    Axes (each in [-1, 1]) scale to ``max_speed_mps`` and ``max_rate_radps``; the left button
    records a snapshot, the right one quits.
    """

    def __init__(self, max_speed_mps: float = 0.02, max_rate_radps: float = 0.3):
        super().__init__()
        self.max_speed_mps = float(max_speed_mps)
        self.max_rate_radps = float(max_rate_radps)
        self._driver = None

    def open(self) -> None:
        if self.is_open:
            return
        try:
            import pyspacemouse
        except ImportError as err:
            raise ImportError("SpaceMouseDevice needs the optional package pyspacemouse: "
                              "pip install -e .[teleop] (or pip install pyspacemouse)") from err
        if not pyspacemouse.open():
            raise RuntimeError("no SpaceMouse found (is it plugged in, and readable by this user?)")
        self._driver = pyspacemouse
        super().open()

    def close(self) -> None:
        if self._driver is not None:
            self._driver.close()
            self._driver = None
        super().close()

    def _poll(self) -> TeleopCommand:
        state = self._driver.read()
        pressed = list(getattr(state, "buttons", []) or [])
        buttons = {name for name, down in zip(("record", "quit"), pressed) if down}
        return TeleopCommand(self.max_speed_mps * np.array([state.x, state.y, state.z], float),
                             self.max_rate_radps * np.array([state.roll, state.pitch, state.yaw], float),
                             frozenset(buttons))


@dataclass(frozen=True)
class TimedCommand:
    """A command held for ``duration_s`` seconds."""

    duration_s: float
    command: TeleopCommand

    def __post_init__(self):
        if not (np.isfinite(self.duration_s) and self.duration_s > 0):
            raise ValueError(f"duration_s must be a positive number of seconds, got {self.duration_s!r}")


class ScriptedDevice(InputDevice):
    """Plays a list of timed commands against a clock (for tests and repeatable sessions).

    Each command's buttons are reported once, at its first poll; after the last command the
    device asks to quit.

    Parameters
    ----------
    steps : sequence of TimedCommand
    clock : callable () -> float
        The session's clock, seconds (simulation time); the script starts at the first poll.
    """

    def __init__(self, steps: Sequence[TimedCommand], clock: Callable[[], float]):
        super().__init__()
        if not steps:
            raise ValueError("a script needs at least one step")
        self.steps = tuple(steps)
        self._ends = np.cumsum([s.duration_s for s in self.steps])
        self._clock = clock
        self._t0: float | None = None
        self._reported = -1

    @classmethod
    def from_json(cls, path: Path, clock: Callable[[], float]) -> "ScriptedDevice":
        """A script file: a JSON list of ``{"duration_s", "linear_mps", "angular_radps", "buttons"}``."""
        try:
            items = json.loads(Path(path).read_text())
        except (ValueError, UnicodeDecodeError) as err:
            raise ValueError(f"script file {path} is not JSON ({err}); a script is a JSON list of "
                             f'{{"duration_s", "linear_mps", "angular_radps", "buttons"}} steps') from None
        if not isinstance(items, list):
            raise ValueError(f"{path}: a script is a JSON list of steps")
        steps = []
        for i, item in enumerate(items):
            try:
                steps.append(TimedCommand(float(item["duration_s"]), TeleopCommand(
                    item.get("linear_mps", [0, 0, 0]), item.get("angular_radps", [0, 0, 0]),
                    frozenset(item.get("buttons", ())))))
            except (KeyError, TypeError, ValueError) as err:
                raise ValueError(f"{path}: step {i}: {err}") from err
        return cls(steps, clock)

    @property
    def duration_s(self) -> float:
        return float(self._ends[-1])

    def _poll(self) -> TeleopCommand:
        now = self._clock()
        if self._t0 is None:
            self._t0 = now
        index = int(np.searchsorted(self._ends, now - self._t0, side="right"))
        if index >= len(self.steps):
            return TeleopCommand(buttons=frozenset({"quit"}))
        step = self.steps[index].command
        first_poll = index != self._reported
        self._reported = index
        return TeleopCommand(step.linear_mps, step.angular_radps, step.buttons if first_poll else frozenset())
