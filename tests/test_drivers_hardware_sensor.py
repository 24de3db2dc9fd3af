"""HardwareTactileSensor over emulated chips and an emulated microcontroller stream."""
import threading
import time

import numpy as np
import pytest

from sensor.drivers import (BMP280, BNO055I2C, BNO055UART, DeviceDisconnectedError,
                            DeviceTimeoutError, HardwareTactileSensor, MicrocontrollerStream,
                            OperationMode)
from sensor.emulators import (BMP280Chip, BNO055Chip, FakeBNO055Serial, FakeClock,
                              FakeMicrocontrollerSerial, FakeSMBus, Fault)
from sensor.interface import TactileSensor
from sensor.reading import Reading

Q = np.array([0.6, 0.0, 0.8, 0.0])


def chip_sensor(imu_transport="i2c", **options):
    clock = FakeClock(10.0)
    barometer_chip = BMP280Chip(pressure_pa=100_500.0, temperature_c=28.0)
    imu_chip = BNO055Chip(clock=clock.monotonic)
    imu_chip.quat_wxyz = Q
    bus = FakeSMBus({0x76: barometer_chip, 0x28: imu_chip})
    barometer = BMP280(bus, sleep=clock.sleep, clock=clock.monotonic)
    if imu_transport == "i2c":
        imu = BNO055I2C(bus, sleep=clock.sleep, clock=clock.monotonic)
    else:
        imu = BNO055UART(FakeBNO055Serial(imu_chip, clock=clock), sleep=clock.sleep,
                         clock=clock.monotonic)
    sensor = HardwareTactileSensor.from_chips(barometer, imu, clock=clock.monotonic,
                                              sleep=clock.sleep, **options)
    return sensor, barometer_chip, imu_chip, clock


@pytest.mark.parametrize("imu_transport", ["i2c", "uart"])
def test_chip_sensor_produces_readings_with_host_timestamps(imu_transport):
    sensor, barometer_chip, imu_chip, clock = chip_sensor(imu_transport)
    assert isinstance(sensor, TactileSensor)
    with sensor:
        assert imu_chip.mode == OperationMode.NDOF  # set in open()
        first = sensor.read()
        clock.advance(0.01)
        barometer_chip.pressure_pa = 100_650.0  # a contact
        second = sensor.read()
        clock.advance(0.01)
        third = sensor.read()
        drained = sensor.drain()
    assert isinstance(first, Reading)
    assert first.pressure_pa == pytest.approx(100_500.0, abs=0.7)
    assert second.pressure_pa == pytest.approx(100_650.0, abs=0.7)
    assert first.temperature_c == pytest.approx(28.0, abs=0.01)
    assert first.quat_wxyz == pytest.approx(Q, abs=1e-4)
    assert first.gravity_mps2 == pytest.approx([0, 0, 9.81], abs=0.01)
    assert 10.0 < first.t_s < second.t_s < third.t_s <= clock.now
    assert [r.t_s for r in drained[:3]] == [first.t_s, second.t_s, third.t_s]
    assert len(drained) == 4  # three reads plus drain's own poll


def test_sensor_must_be_open_and_open_close_are_idempotent():
    sensor, *_ = chip_sensor()
    with pytest.raises(RuntimeError, match="not open"):
        sensor.read()
    sensor.open()
    sensor.open()
    assert sensor.is_open
    sensor.close()
    sensor.close()
    with pytest.raises(RuntimeError, match="not open"):
        sensor.drain()


def test_imu_mode_must_be_a_fusion_mode():
    with pytest.raises(ValueError, match="fusion mode"):
        chip_sensor(imu_mode=OperationMode.AMG)


def test_buffer_overflow_keeps_the_newest_and_counts_the_dropped():
    sensor, *_ = chip_sensor(max_buffered=5)
    with sensor:
        newest = [sensor.read() for _ in range(8)][-1]
        drained = sensor.drain()
    assert sensor.dropped == 4 and len(drained) == 5 and drained[-2] is newest


def test_silent_stream_read_times_out():
    clock = FakeClock()
    port = FakeMicrocontrollerSerial(clock=clock)
    sensor = HardwareTactileSensor.from_stream(MicrocontrollerStream(port, clock=clock.monotonic),
                                               background=False, sleep=clock.sleep,
                                               read_timeout_s=0.5)
    with sensor, pytest.raises(DeviceTimeoutError, match="no reading within 0.5 s"):
        sensor.read()


def wait_for(predicate, timeout_s=5.0):
    deadline = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError("condition not reached in time")
        time.sleep(0.002)


def test_stream_sensor_reads_in_a_background_thread_started_by_open():
    port = FakeMicrocontrollerSerial(timeout=0.001)
    port.queue_bytes(b"$T,stale line from before open*00\r\n")
    sensor = HardwareTactileSensor.from_stream(MicrocontrollerStream(port), poll_period_s=0.0005)
    threads_before = threading.active_count()
    assert threading.active_count() == threads_before  # nothing started by the constructor
    collected = []
    with sensor:
        assert threading.active_count() == threads_before + 1
        for i in range(40):
            port.queue_sample(1000 + 10 * i, 100_000.0 + i, quat_wxyz=Q)
        wait_for(lambda: collected.extend(sensor.drain()) or len(collected) >= 40)
        newest = sensor.read()
    assert threading.active_count() == threads_before  # stopped by close()
    assert [r.pressure_pa for r in collected] == [100_000.0 + i for i in range(40)]
    assert newest.pressure_pa == 100_039.0
    assert np.all(np.diff([r.t_s for r in collected]) >= 0)
    assert sensor.source.stream.stats.skipped == 0  # the stale line was flushed by open()


def test_background_errors_reach_the_caller_and_stay():
    port = FakeMicrocontrollerSerial(timeout=0.001)
    sensor = HardwareTactileSensor.from_stream(MicrocontrollerStream(port), poll_period_s=0.0005)
    with sensor:
        port.faults.inject(Fault.DISCONNECT)
        wait_for(lambda: sensor._thread_error is not None)
        for _ in range(2):
            with pytest.raises(DeviceDisconnectedError, match="microcontroller stream"):
                sensor.drain()
    assert not sensor.is_open
