"""Fault-injection suite: every injected fault is either survived (the true value comes back)
or ends in the specific exception, naming the device and the register."""
import pytest

from sensor.drivers import BMP280, BNO055I2C, ChipIdError, DeviceError
from sensor.drivers.bno055_registers import register_label
from sensor.emulators import BMP280Chip, FakeClock, FakeSMBus, Fault
from sensor.emulators.fault_campaign import CASES, run_case

DEVICE_NAMES = {"bmp280/i2c": "BMP280 at I2C 0x76", "bno055/i2c": "BNO055 at I2C 0x28",
                "bno055/uart": "BNO055 over UART", "mcu/serial": "microcontroller stream"}


@pytest.mark.parametrize("case", CASES, ids=lambda case: case.name)
def test_fault_is_survived_or_reported_by_name(case):
    outcome = run_case(case)
    assert outcome.triggered >= 1, "the fault never fired"
    if case.expect is None:
        assert outcome.error is None, f"did not recover: {outcome.error!r}"
        assert outcome.value_ok, "recovered with a wrong value"
        return
    assert isinstance(outcome.error, case.expect), f"got {outcome.error!r}"
    assert isinstance(outcome.error, DeviceError)
    message = str(outcome.error)
    assert DEVICE_NAMES[case.target.split(" ")[0]] in message
    if case.register is not None:
        assert outcome.error.register == case.register
        assert f"0x{case.register:02X}" in message
        if case.target.startswith("bno055/uart") and case.fault is not Fault.DISCONNECT:
            assert register_label(case.register) in message  # e.g. QUA_DATA_W_LSB


def test_campaign_covers_every_fault_kind_with_both_outcomes():
    kinds = {case.fault for case in CASES}
    assert kinds == set(Fault)
    assert any(case.expect is None for case in CASES) and any(case.expect for case in CASES)


def test_retries_are_bounded_by_the_attempt_count():
    # A bus that NACKs forever is asked exactly `attempts` times, then the error is raised.
    clock = FakeClock()
    bus = FakeSMBus({0x76: BMP280Chip()})
    barometer = BMP280(bus, sleep=clock.sleep, clock=clock.monotonic, attempts=5)
    bus.faults.inject(Fault.NACK, times=1000, register=0xF7)
    with pytest.raises(DeviceError):
        barometer.read()
    assert bus.faults.triggered[Fault.NACK] == 5


def test_another_chip_at_the_imu_address_is_named():
    bus = FakeSMBus({0x28: BMP280Chip()})  # wrong chip wired where the BNO055 should be
    with pytest.raises(ChipIdError, match=r"BNO055 at I2C 0x28.*0x00 read, expected 0xA0"):
        BNO055I2C(bus, sleep=lambda s: None)
