"""Real arms behind :class:`robots.interface.Robot`.

* :class:`JointInterface` - the five methods a robot's own API must offer (encoders in, joint
  targets out, stop); plug a ROS or vendor-SDK adapter in here (``docs/HARDWARE.md``).
* :class:`HardwareArm` - the Robot on any JointInterface: streamed targets, guarded moves,
  STOP on every error.
* :class:`CompliantArm` - a read-only view for hand-guided (teleop) exploration in the robot's
  own compliant mode: encoders are read, motion commands refused.
* :class:`SerialArm` / :class:`SerialJointInterface` - the line protocol of
  ``docs/ROBOT_PROTOCOL.md`` over a serial port (emulator: :mod:`robots.emulators`).

Nothing here imports pyserial until a port is opened by name.
"""
from robots.hardware.arm import HardwareArm, SerialArm
from robots.hardware.compliant import CompliantArm, CompliantModeError
from robots.hardware.errors import (RobotCommandError, RobotConnectionError, RobotFaultError, RobotHardwareError,
                                    RobotNotOpenError, RobotProtocolError, RobotWatchdogError)
from robots.hardware.joint_interface import EncoderReading, JointInterface
from robots.hardware.protocol import ControllerStatus, ErrorCode
from robots.hardware.serial_joints import LinkStats, SerialJointInterface

__all__ = [
    "HardwareArm", "SerialArm", "CompliantArm", "CompliantModeError", "JointInterface", "EncoderReading", "SerialJointInterface", "LinkStats",
    "ControllerStatus", "ErrorCode",
    "RobotHardwareError", "RobotNotOpenError", "RobotConnectionError", "RobotProtocolError",
    "RobotCommandError", "RobotFaultError", "RobotWatchdogError",
]
