"""Exceptions of the robot hardware backends.

Every error names the device (``"arm on /dev/ttyUSB0"``) and what happened; an error raised while
the arm was moving also says during which call and what became of the STOP sent afterwards, e.g.
``arm on /dev/ttyUSB0: no encoder reply for 0.20 s (4 attempts) during guarded_move; STOP could
not be confirmed (no STOP reply for 0.20 s (4 attempts))``.
"""
from __future__ import annotations


class RobotHardwareError(Exception):
    """Base class: something went wrong talking to a real (or emulated) arm controller.

    Attributes
    ----------
    device : str
        Which arm and link, e.g. ``"arm on /dev/ttyUSB0"``.
    detail : str
        What happened.
    context : str
        Empty, or where it happened and what was done about it (``"during guarded_move; ..."``).
    """

    def __init__(self, device: str, detail: str, context: str = ""):
        self.device = device
        self.detail = detail
        self.context = context
        super().__init__(self._message())

    def _message(self) -> str:
        return f"{self.device}: {self.detail}" + (f" {self.context}" if self.context else "")

    def during(self, context: str) -> "RobotHardwareError":
        """A copy of this error with ``context`` appended to its message."""
        annotated = type(self).__new__(type(self))
        annotated.__dict__.update(self.__dict__)
        annotated.context = context
        annotated.args = (annotated._message(),)
        return annotated


class RobotNotOpenError(RobotHardwareError, RuntimeError):
    """The backend was used before ``open()`` (or after ``close()``)."""


class RobotConnectionError(RobotHardwareError, ConnectionError):
    """The controller stopped answering, or the port failed (cable pulled, adapter reset)."""


class RobotProtocolError(RobotHardwareError):
    """The controller answered, but only with frames that could not be understood."""


class RobotCommandError(RobotHardwareError, ValueError):
    """The controller refused a command (error reply), e.g. a target outside its joint limits.

    Attributes
    ----------
    code : int
        The protocol's error code.
    """

    def __init__(self, device: str, detail: str, code: int, context: str = ""):
        self.code = code
        super().__init__(device, detail, context)


class RobotFaultError(RobotHardwareError):
    """The controller reports a latched fault (drive fault, emergency stop, ...); it has stopped.

    Attributes
    ----------
    status : int
        The controller status code (see ``docs/ROBOT_PROTOCOL.md``).
    """

    def __init__(self, device: str, detail: str, status: int, context: str = ""):
        self.status = status
        super().__init__(device, detail, context)


class RobotWatchdogError(RobotHardwareError):
    """The controller's watchdog stopped the arm: no command reached it within its timeout."""
