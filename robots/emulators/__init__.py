"""An emulated arm controller, so that the hardware backend can be tested and demonstrated without a robot.

* :class:`EmulatedArmController` - executes the line protocol of ``docs/ROBOT_PROTOCOL.md``:
  first-order joints, joint limits, encoder quantisation, watchdog, latched faults;
* :class:`FakeArmSerial` - a pyserial-like port to it, with :class:`ArmFault` injection;
* :func:`register_serial_url_handlers` - ``serial.serial_for_url("armemu://armar3")`` (needs pyserial);
* :mod:`robots.emulators.fault_campaign` - every injected fault against the backend
  (``python -m robots.emulators.fault_campaign``).
"""
from robots.emulators.arm_controller import EmulatedArmController
from robots.emulators.arm_serial import ArmFault, ArmFaultInjector, ArmPortDisconnectedError, FakeArmSerial
from common.serial_urls import register_serial_url_package

PACKAGE = "robots.emulators"


def register_serial_url_handlers() -> None:
    """Let ``serial.serial_for_url`` open ``armemu://<robot>``. Idempotent."""
    register_serial_url_package(PACKAGE, "the armemu:// URL")


__all__ = ["EmulatedArmController", "FakeArmSerial", "ArmFault", "ArmFaultInjector", "ArmPortDisconnectedError",
           "register_serial_url_handlers"]
