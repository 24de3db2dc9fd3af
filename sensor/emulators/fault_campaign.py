"""Fault-injection campaign: each injected fault against the driver that must survive it.

Every :class:`FaultCase` builds fresh emulators, injects one fault pattern and runs one driver
operation. The expectation is either recovery (the operation returns the emulator's true value)
or a specific exception naming the device and register. ``python -m
sensor.emulators.fault_campaign`` prints the table and the totals; the test suite asserts each
case.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from typing import Callable

import numpy as np

from sensor.drivers import (BMP280, BNO055I2C, BNO055UART, BusError, CalibrationProfile,
                            DeviceDisconnectedError, DeviceTimeoutError, HardwareTactileSensor,
                            MicrocontrollerStream, OperationMode, ProtocolError)
from sensor.emulators.bmp280_chip import BMP280Chip
from sensor.emulators.bno055_chip import BNO055Chip
from sensor.emulators.bno055_serial import FakeBNO055Serial
from common.clock import FakeClock
from sensor.emulators.fake_smbus import FakeSMBus
from sensor.emulators.faults import Fault
from sensor.emulators.mcu_serial import FakeMicrocontrollerSerial

TRUE_PRESSURE_PA = 100_250.0
TRUE_QUATERNION = np.array([0.8, 0.2, -0.4, 0.4]) / np.linalg.norm([0.8, 0.2, -0.4, 0.4])
PROFILE = CalibrationProfile((-12, 7, 30), (210, -95, 400), (-1, 2, 0), 1000, 730)


@dataclass(frozen=True)
class FaultCase:
    """One fault pattern and what the driver must do about it.

    Attributes
    ----------
    target : str
        ``"bmp280/i2c read"``, ``"bno055/i2c quaternion"``, ``"bno055/i2c write_calibration"``,
        ``"bno055/uart quaternion"``, ``"bno055/uart set_mode"`` or ``"mcu/serial read"``.
    fault : Fault
    times : int
        Consecutive transactions hit.
    expect : type or None
        Exception the driver must raise; None means it must recover.
    register : int or None
        Register the fault is aimed at (and that the error must name).
    """

    target: str
    fault: Fault
    times: int
    expect: type[Exception] | None
    register: int | None

    @property
    def name(self) -> str:
        outcome = "recover" if self.expect is None else self.expect.__name__
        return f"{self.target}: {self.fault.name} x{self.times} -> {outcome}"


@dataclass
class FaultOutcome:
    case: FaultCase
    error: Exception | None
    value_ok: bool
    triggered: int

    @property
    def as_expected(self) -> bool:
        if self.triggered == 0:
            return False  # the fault never fired: the case proves nothing
        if self.case.expect is None:
            return self.error is None and self.value_ok
        return isinstance(self.error, self.case.expect)


def _bmp280_read(case: FaultCase, clock: FakeClock):
    bus = FakeSMBus({0x76: BMP280Chip(pressure_pa=TRUE_PRESSURE_PA)})
    barometer = BMP280(bus, sleep=clock.sleep, clock=clock.monotonic)
    bus.faults.inject(case.fault, case.times, case.register)
    return bus.faults, lambda: abs(barometer.read()[0] - TRUE_PRESSURE_PA) < 1.0


def _bno055_i2c(case: FaultCase, clock: FakeClock):
    chip = BNO055Chip(clock=clock.monotonic)
    chip.quat_wxyz = TRUE_QUATERNION
    bus = FakeSMBus({0x28: chip})
    imu = BNO055I2C(bus, sleep=clock.sleep, clock=clock.monotonic)
    imu.set_mode(OperationMode.NDOF)
    bus.faults.inject(case.fault, case.times, case.register)
    return bus.faults, _operation(case, imu, chip)


def _bno055_uart(case: FaultCase, clock: FakeClock):
    port = FakeBNO055Serial(clock=clock)
    port.chip.quat_wxyz = TRUE_QUATERNION
    imu = BNO055UART(port, sleep=clock.sleep, clock=clock.monotonic)
    if not case.target.endswith("set_mode"):
        imu.set_mode(OperationMode.NDOF)
    port.faults.inject(case.fault, case.times, case.register)
    return port.faults, _operation(case, imu, port.chip)


def _operation(case: FaultCase, imu, chip: BNO055Chip) -> Callable[[], bool]:
    if case.target.endswith("quaternion"):
        return lambda: np.allclose(imu.quaternion(), TRUE_QUATERNION, atol=1e-3)
    if case.target.endswith("write_calibration"):
        def write_calibration() -> bool:
            imu.write_calibration(PROFILE)
            return chip.calibration_bytes == PROFILE.to_bytes() and chip.mode == OperationMode.NDOF
        return write_calibration

    def set_mode() -> bool:
        imu.set_mode(OperationMode.NDOF)
        return chip.mode == OperationMode.NDOF
    return set_mode


def _mcu_read(case: FaultCase, clock: FakeClock):
    port = FakeMicrocontrollerSerial(clock=clock)
    sensor = HardwareTactileSensor.from_stream(MicrocontrollerStream(port, clock=clock.monotonic),
                                               background=False, sleep=clock.sleep, read_timeout_s=0.2)
    sensor.open()
    port.faults.inject(case.fault, case.times)
    port.queue_sample(1000, TRUE_PRESSURE_PA)
    return port.faults, lambda: abs(sensor.read().pressure_pa - TRUE_PRESSURE_PA) < 0.01


_BUILDERS = {"bmp280/i2c": _bmp280_read, "bno055/i2c": _bno055_i2c, "bno055/uart": _bno055_uart,
             "mcu/serial": _mcu_read}


def run_case(case: FaultCase) -> FaultOutcome:
    """Build the emulators, inject the fault, run the operation and record what happened."""
    clock = FakeClock()
    faults, operation = _BUILDERS[case.target.split(" ")[0]](case, clock)
    try:
        value_ok = bool(operation())
        error = None
    except Exception as exc:  # the outcome is judged against the case's expectation
        value_ok, error = False, exc
    return FaultOutcome(case, error, value_ok, faults.triggered[case.fault])


def _cases() -> list[FaultCase]:
    F = Fault
    bmp, bno_i2c, bno_cal = "bmp280/i2c read", "bno055/i2c quaternion", "bno055/i2c write_calibration"
    uart, uart_mode, mcu = "bno055/uart quaternion", "bno055/uart set_mode", "mcu/serial read"
    return [
        FaultCase(bmp, F.NACK, 1, None, 0xF7),
        FaultCase(bmp, F.NACK, 2, None, 0xF7),
        FaultCase(bmp, F.NACK, 3, BusError, 0xF7),
        FaultCase(bmp, F.IO_ERROR, 1, None, 0xF7),
        FaultCase(bmp, F.BUS_TIMEOUT, 2, None, 0xF7),
        FaultCase(bmp, F.BUS_TIMEOUT, 3, DeviceTimeoutError, 0xF7),
        FaultCase(bmp, F.DISCONNECT, 1, BusError, 0xF7),
        FaultCase(bno_i2c, F.NACK, 1, None, 0x20),
        FaultCase(bno_i2c, F.NACK, 3, BusError, 0x20),
        FaultCase(bno_i2c, F.IO_ERROR, 2, None, 0x20),
        FaultCase(bno_i2c, F.BUS_TIMEOUT, 1, None, 0x20),
        FaultCase(bno_i2c, F.DISCONNECT, 1, BusError, 0x20),
        FaultCase(bno_cal, F.NACK, 1, None, 0x55),
        FaultCase(bno_cal, F.NACK, 3, BusError, 0x55),
        FaultCase(uart, F.OVERRUN, 1, None, 0x20),
        FaultCase(uart, F.OVERRUN, 3, None, 0x20),
        FaultCase(uart, F.OVERRUN, 4, BusError, 0x20),
        FaultCase(uart, F.FAIL_STATUS, 2, None, 0x20),
        FaultCase(uart, F.NO_REPLY, 1, None, 0x20),
        FaultCase(uart, F.NO_REPLY, 4, DeviceTimeoutError, 0x20),
        FaultCase(uart, F.TRUNCATED, 1, None, 0x20),
        FaultCase(uart, F.TRUNCATED, 4, DeviceTimeoutError, 0x20),
        FaultCase(uart, F.GARBAGE, 1, None, 0x20),
        FaultCase(uart, F.GARBAGE, 6, None, 0x20),
        FaultCase(uart, F.INVALID_ADDRESS, 1, ProtocolError, 0x20),
        FaultCase(uart, F.DISCONNECT, 1, DeviceDisconnectedError, 0x20),
        FaultCase(uart, F.SILENT, 1, DeviceTimeoutError, 0x20),
        FaultCase(uart_mode, F.OVERRUN, 1, None, 0x3D),
        FaultCase(uart_mode, F.FAIL_STATUS, 1, None, 0x3D),
        FaultCase(uart_mode, F.NO_REPLY, 1, None, 0x3D),
        FaultCase(uart_mode, F.GARBAGE, 1, None, 0x3D),
        FaultCase(uart_mode, F.DISCONNECT, 1, DeviceDisconnectedError, 0x3D),
        FaultCase(mcu, F.DISCONNECT, 1, DeviceDisconnectedError, None),
        FaultCase(mcu, F.SILENT, 1, DeviceTimeoutError, None),
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
        print(f"{verdict:10s} {outcome.case.name}{detail}")
    print(f"\nfault cases tried: {len(outcomes)}; as expected: {totals['ok']} "
          f"(recovered {totals['recovered']}, failed cleanly with the expected error "
          f"{totals['named error']}); unexpected: {totals['UNEXPECTED']}")


if __name__ == "__main__":
    main()
