"""JointInterface: where a real robot's own API plugs into the framework.

:class:`~robots.hardware.arm.HardwareArm` turns any JointInterface into a
:class:`robots.interface.Robot` (streamed joint targets, guarded moves, STOP on every error).
:class:`~robots.hardware.serial_joints.SerialJointInterface` implements it for the line protocol
of ``docs/ROBOT_PROTOCOL.md``; a ROS or vendor-SDK adapter implements the same five methods
(skeleton in ``docs/HARDWARE.md``).
"""
from __future__ import annotations

import abc
from typing import NamedTuple

import numpy as np


class EncoderReading(NamedTuple):
    """Joint encoders at one instant (unpacks as ``t_s, q = joints.read_encoders()``).

    Attributes
    ----------
    t_s : float
        Host monotonic time the encoders were latched, seconds.
    q : (dof,) float
        Joint positions, radians, in the robot spec's ``joint_names`` order.
    """

    t_s: float
    q: np.ndarray


class JointInterface(abc.ABC):
    """Encoders in, joint position targets out.

    Contract
    --------
    * No I/O before :meth:`open`; :meth:`close` releases everything and is idempotent.
    * :meth:`command` sets a position target and returns at once; the host calls it at its
      control rate with targets close to the current position (one tick of motion apart).
    * :meth:`stop` makes the arm hold where it is now and returns once the controller has
      accepted it.
    * Failures raise :class:`~robots.hardware.errors.RobotHardwareError` subclasses that name
      :attr:`device`: ``RobotConnectionError`` (no answer, link lost), ``RobotFaultError``
      (controller fault), ``RobotWatchdogError``, ``RobotCommandError``, ``RobotProtocolError``.
    """

    @property
    @abc.abstractmethod
    def device(self) -> str:
        """Names the arm and its link in messages, e.g. ``"arm on /dev/ttyUSB0"``."""

    @property
    @abc.abstractmethod
    def dof(self) -> int:
        """Number of joints read and commanded."""

    @abc.abstractmethod
    def open(self) -> None:
        """Connect and check that the controller is the expected one. Idempotent."""

    @abc.abstractmethod
    def close(self) -> None:
        """Disconnect (leaving the arm holding). Idempotent."""

    @abc.abstractmethod
    def read_encoders(self) -> EncoderReading:
        """The current joint positions and the host time they were measured."""

    @abc.abstractmethod
    def command(self, q: np.ndarray) -> None:
        """Set the joint position target ``q`` ((dof,) radians)."""

    @abc.abstractmethod
    def stop(self) -> None:
        """Hold the current position."""
