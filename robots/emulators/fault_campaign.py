"""Fault-injection campaign: each injected controller-link fault against :class:`robots.hardware.SerialArm`.

Every :class:`ArmFaultCase` builds a fresh emulated controller on a fake clock, injects one fault
pattern, runs one backend operation (``open``, ``read`` = ``joint_positions()``, or a
``guarded_move`` with the fault striking mid-path) and records the outcome: recovered (the
operation returned the right value) or the expected error, whose message must name the port and
the given fragments. Either way the emulated arm must be left stopped: one watchdog period later
it is not moving and has drifted by less than ``MAX_DRIFT_RAD`` since the operation ended.

``python -m robots.emulators.fault_campaign`` prints the table and the totals; the test suite
asserts every case.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import numpy as np

from robots.emulators.arm_controller import EmulatedArmController
from robots.emulators.arm_serial import ArmFault, FakeArmSerial
from robots.hardware import (RobotConnectionError, RobotFaultError, RobotProtocolError, RobotWatchdogError,
                             SerialArm)
from robots.hardware.protocol import ControllerStatus
from robots.registry import load
from common.clock import FakeClock

PORT = "/dev/ttyEMU0"
ROBOT = "armar3"
MOVE_DELTA_RAD = np.radians([10.0, 8.0, -6.0, 12.0, -5.0, 4.0, -7.0])
MOVE_SPEED_RAD_S = 0.5
FAULT_AFTER_REQUESTS = 20  # mid-path: the move streams ~40 ticks of GETQ + SETQ
ENCODER_RESOLUTION_RAD = 1e-4
MAX_DRIFT_RAD = 0.02  # after an error the arm may finish at most about a tick's worth of motion


@dataclass(frozen=True)
class ArmFaultCase:
    """One fault pattern and what the backend must do about it.

    Attributes
    ----------
    operation : str
        ``"open"``, ``"read"`` or ``"guarded_move"``.
    fault : ArmFault or None
        None for a host stall (see ``host_stall_s``).
    times : int
        Consecutive matching requests hit.
    command : str or None
        Only requests of this command are hit (None: any).
    after : int
        Matching requests let through before the fault strikes.
    expect : type or None
        Exception the backend must raise; None means it must recover.
    message : tuple of str
        Fragments the error message must contain (besides the port name).
    host_stall_s : float
        The move's ``stop()`` predicate stalls the host this long once, mid-path.
    """

    operation: str
    fault: ArmFault | None
    times: int = 1
    command: str | None = None
    after: int = 0
    expect: type[Exception] | None = None
    message: tuple[str, ...] = ()
    host_stall_s: float = 0.0

    @property
    def name(self) -> str:
        what = f"host stall {self.host_stall_s:.1f} s" if self.fault is None else \
            f"{self.fault.name} x{self.times} on {self.command or 'any'}"
        outcome = "recover" if self.expect is None else self.expect.__name__
        return f"{self.operation}: {what} -> {outcome}"


@dataclass
class ArmFaultOutcome:
    """What happened in one case.

    Attributes
    ----------
    error : Exception or None
    value_ok : bool
        The operation returned the right value (only meaningful when it returned).
    triggered : int
        Requests the fault hit (watchdog trips for a host stall).
    stopped : bool
        The emulated arm was not moving one watchdog period after the operation.
    drift_rad : float
        Largest joint motion between the end of the operation and that check, radians.
    """

    case: ArmFaultCase
    error: Exception | None
    value_ok: bool
    triggered: int
    stopped: bool
    drift_rad: float

    @property
    def message_ok(self) -> bool:
        if self.error is None:
            return True
        text = str(self.error)
        return PORT in text and all(fragment in text for fragment in self.case.message)

    @property
    def as_expected(self) -> bool:
        if self.triggered == 0 or not self.stopped or self.drift_rad > MAX_DRIFT_RAD:
            return False  # a fault that never fired proves nothing; a moving arm is never fine
        if self.case.expect is None:
            return self.error is None and self.value_ok
        return isinstance(self.error, self.case.expect) and self.message_ok


def run_case(case: ArmFaultCase) -> ArmFaultOutcome:
    """Build the emulator, inject the fault, run the operation and record what happened."""
    clock = FakeClock()
    spec = load(ROBOT)
    controller = EmulatedArmController.for_spec(spec, clock=clock.monotonic,
                                                encoder_resolution_rad=ENCODER_RESOLUTION_RAD)
    port = FakeArmSerial(controller, clock=clock, port=PORT)
    arm = SerialArm(port, spec, clock=clock.monotonic, sleep=clock.sleep)
    if case.fault is not None and case.operation != "open":
        arm.open()
    if case.fault is not None:
        port.faults.inject(case.fault, case.times, case.command, case.after)
    error, value_ok = None, False
    try:
        value_ok = _OPERATIONS[case.operation](arm, controller, clock, case)
    except Exception as exc:  # judged against the case's expectation
        error = exc
    q_end = controller.true_q
    clock.advance(controller.watchdog_s + 10 * controller.time_constant_s)
    drift = float(np.max(np.abs(controller.true_q - q_end)))
    stopped = not controller.is_moving and controller.status != ControllerStatus.TRACKING
    triggered = controller.watchdog_trips if case.fault is None else port.faults.triggered[case.fault]
    return ArmFaultOutcome(case, error, value_ok, triggered, stopped, drift)


def _open(arm: SerialArm, controller: EmulatedArmController, clock: FakeClock, case: ArmFaultCase) -> bool:
    arm.open()
    return arm.joints.hello is not None and arm.joints.hello.dof == controller.dof


def _read(arm: SerialArm, controller: EmulatedArmController, clock: FakeClock, case: ArmFaultCase) -> bool:
    return bool(np.allclose(arm.joint_positions(), controller.encoder_q, rtol=0.0, atol=1e-6))


def _guarded_move(arm: SerialArm, controller: EmulatedArmController, clock: FakeClock, case: ArmFaultCase) -> bool:
    if case.fault is None:
        arm.open()
    target = controller.encoder_q + MOVE_DELTA_RAD
    calls = 0

    def stop() -> bool:
        nonlocal calls
        calls += 1
        if case.host_stall_s and calls == FAULT_AFTER_REQUESTS // 2:
            clock.advance(case.host_stall_s)
        return False

    result = arm.guarded_move(target[None], stop, speed_rad_s=MOVE_SPEED_RAD_S)
    return not result.stopped and float(np.max(np.abs(result.q - target))) <= arm.reached_tolerance_rad


_OPERATIONS = {"open": _open, "read": _read, "guarded_move": _guarded_move}


def _cases() -> list[ArmFaultCase]:
    F, C = ArmFault, ArmFaultCase
    lost, corrupt = RobotConnectionError, RobotProtocolError
    mid = FAULT_AFTER_REQUESTS
    return [
        C("open", F.NO_REPLY, 1, "HELLO"),
        C("open", F.GARBAGE, 1, "HELLO"),
        C("open", F.NO_REPLY, 4, "HELLO", expect=lost, message=("no HELLO reply",)),
        C("open", F.DISCONNECT, 1, expect=lost, message=("port failed",)),
        C("read", F.NO_REPLY, 1, "GETQ"),
        C("read", F.NO_REPLY, 3, "GETQ"),
        C("read", F.NO_REPLY, 4, "GETQ", expect=lost, message=("no encoder reply for 0.2",)),
        C("read", F.GARBAGE, 2, "GETQ"),
        C("read", F.CORRUPT, 3, "GETQ"),
        C("read", F.CORRUPT, 4, "GETQ", expect=corrupt, message=("corrupted frames",)),
        C("read", F.TRUNCATED, 3, "GETQ"),
        C("read", F.DELAYED, 3, "GETQ"),
        C("read", F.DRIVE_FAULT, 1, "GETQ", expect=RobotFaultError, message=("DRIVE_FAULT",)),
        C("guarded_move", F.NO_REPLY, 1, "GETQ", mid),
        C("guarded_move", F.NO_REPLY, 3, "GETQ", mid),
        C("guarded_move", F.NO_REPLY, 50, "GETQ", mid, expect=lost,
          message=("no encoder reply for 0.2", "during guarded_move", "STOP sent and acknowledged")),
        C("guarded_move", F.NO_REPLY, 2, "SETQ", mid),
        C("guarded_move", F.NO_REPLY, 50, "SETQ", mid, expect=lost,
          message=("no SETQ reply", "during guarded_move", "STOP sent and acknowledged")),
        C("guarded_move", F.LOST_REPLY, 3, "SETQ", mid),
        C("guarded_move", F.GARBAGE, 6, None, mid),
        C("guarded_move", F.CORRUPT, 3, "GETQ", mid),
        C("guarded_move", F.CORRUPT, 50, "GETQ", mid, expect=corrupt,
          message=("corrupted frames", "during guarded_move", "STOP sent and acknowledged")),
        C("guarded_move", F.TRUNCATED, 3, None, mid),
        C("guarded_move", F.DELAYED, 3, "GETQ", mid),
        C("guarded_move", F.DELAYED, 3, "SETQ", mid),
        C("guarded_move", F.DISCONNECT, 1, None, mid, expect=lost,
          message=("port failed", "during guarded_move", "STOP could not be confirmed")),
        C("guarded_move", F.SILENT, 1, None, mid, expect=lost,
          message=("reply for 0.2", "during guarded_move", "STOP could not be confirmed")),
        C("guarded_move", F.DRIVE_FAULT, 1, "GETQ", mid, expect=RobotFaultError,
          message=("DRIVE_FAULT", "during guarded_move")),
        C("guarded_move", F.EMERGENCY_STOP, 1, "SETQ", mid, expect=RobotFaultError,
          message=("EMERGENCY_STOP", "during guarded_move")),
        C("guarded_move", None, host_stall_s=0.3, expect=RobotWatchdogError,
          message=("watchdog", "200 ms", "during guarded_move", "STOP sent and acknowledged")),
    ]


CASES = _cases()


def main() -> None:
    outcomes = [run_case(case) for case in CASES]
    totals = Counter()
    for outcome in outcomes:
        kind = "recovered" if outcome.error is None else "named error"
        verdict = "ok" if outcome.as_expected else "UNEXPECTED"
        totals[verdict] += 1
        totals[kind] += outcome.as_expected
        detail = "" if outcome.error is None else f"  [{type(outcome.error).__name__}: {outcome.error}]"
        print(f"{verdict:10s} {outcome.case.name}; arm stopped: {outcome.stopped}, "
              f"drift {np.degrees(outcome.drift_rad):.3f} deg{detail}")
    print(f"\narm fault cases tried: {len(outcomes)}; as expected: {totals['ok']} "
          f"(recovered {totals['recovered']}, failed cleanly with the expected error and the arm stopped "
          f"{totals['named error']}); unexpected: {totals['UNEXPECTED']}")


if __name__ == "__main__":
    main()
