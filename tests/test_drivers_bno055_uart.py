"""BNO055 UART framing (datasheet section 4.7): request bytes, reply parsing across reads,
resynchronisation, retry pacing and port errors."""
import pytest

from sensor.drivers import (BNO055UART, DeviceDisconnectedError, DeviceTimeoutError,
                            OperationMode)
from sensor.drivers.bno055_uart import BNO055UartTransport
from sensor.emulators import FakeBNO055Serial, FakeClock, Fault
from sensor.emulators.bno055_serial import DEFAULT_GARBAGE


class OneBytePerRead(FakeBNO055Serial):
    """A port that hands over replies one byte per read() call, as a slow USB adapter may."""

    def read(self, size=1):
        return super().read(min(size, 1))


def make_imu(port_class=FakeBNO055Serial, **options):
    clock = FakeClock()
    port = port_class(clock=clock)
    sleeps = []

    def sleep(seconds):
        sleeps.append(seconds)
        clock.sleep(seconds)
    imu = BNO055UART(port, sleep=sleep, clock=clock.monotonic, **options)
    return imu, port, sleeps


def test_requests_are_the_datasheet_frames():
    imu, port, _ = make_imu()
    port.requests.clear()
    imu.set_mode(OperationMode.NDOF)
    imu.quaternion()
    assert port.requests == [bytes([0xAA, 0x00, 0x3D, 0x01, 0x0C]),  # write OPR_MODE = NDOF
                             bytes([0xAA, 0x01, 0x20, 0x08])]  # read 8 bytes from QUA_DATA


def test_replies_split_across_reads_are_reassembled():
    imu, port, _ = make_imu(OneBytePerRead)
    port.chip.quat_wxyz = [0.0, 0.6, 0.0, 0.8]
    imu.set_mode(OperationMode.NDOF)
    assert imu.quaternion() == pytest.approx((0.0, 0.6, 0.0, 0.8), abs=1e-4)
    assert imu.link_stats.retries == 0


def test_garbage_before_a_reply_is_skipped_without_retry():
    imu, port, _ = make_imu()
    imu.set_mode(OperationMode.NDOF)
    port.faults.inject(Fault.GARBAGE, times=2)
    imu.quaternion()
    imu.calibration_status()
    assert imu.link_stats.garbage_bytes == 2 * len(DEFAULT_GARBAGE)
    assert imu.link_stats.retries == 0


def test_endless_noise_is_a_bounded_failure():
    imu, port, _ = make_imu()
    port.garbage = bytes([0x00, 0x11]) * 200  # no reply header anywhere near
    port.faults.inject(Fault.GARBAGE, times=10)
    with pytest.raises(Exception, match="no valid reply header") as info:
        imu.calibration_status()
    assert info.value.register == 0x35


def test_retries_back_off_exponentially():
    imu, port, sleeps = make_imu(retry_delay_s=0.002)
    imu.set_mode(OperationMode.NDOF)
    sleeps.clear()
    port.faults.inject(Fault.OVERRUN, times=3)
    imu.quaternion()
    assert [s for s in sleeps if s >= 0.002] == [0.002, 0.004, 0.008]
    assert imu.link_stats.statuses == {"BUS_OVER_RUN_ERROR": 3}
    assert imu.link_stats.retries == 3


def test_stale_bytes_in_the_input_buffer_are_discarded():
    imu, port, _ = make_imu()
    imu.set_mode(OperationMode.NDOF)
    port._to_host += bytes([0xBB, 0x08]) + bytes([0x11] * 8)  # a late reply to an old request
    assert imu.quaternion() == pytest.approx((1.0, 0.0, 0.0, 0.0))


class RaisingPort:
    timeout = 0.01

    def __init__(self, error):
        self.error = error

    def read(self, size=1):
        return b""

    def write(self, data):
        raise self.error


def test_write_timeout_and_port_failure_are_told_apart():
    serial = pytest.importorskip("serial")
    transport = BNO055UartTransport(RaisingPort(serial.SerialTimeoutException("Write timeout")))
    with pytest.raises(DeviceTimeoutError, match="write timeout.*OPR_MODE"):
        transport.write(0x3D, 0x0C)
    transport = BNO055UartTransport(RaisingPort(serial.SerialException("device disconnected")))
    with pytest.raises(DeviceDisconnectedError, match="OPR_MODE.*device disconnected"):
        transport.write(0x3D, 0x0C)


@pytest.mark.parametrize("register, length, problem", [(0x80, 1, "register"), (0x20, 0, "length"),
                                                        (0x20, 129, "length")])
def test_out_of_range_requests_are_value_errors(register, length, problem):
    transport = BNO055UartTransport(FakeBNO055Serial())
    with pytest.raises(ValueError, match=problem):
        transport.read(register, length)


def test_port_objects_are_checked():
    blocking_port = FakeBNO055Serial()
    blocking_port.timeout = None  # pyserial's default: read() waits forever
    with pytest.raises(ValueError, match="timeout=None"):
        BNO055UartTransport(blocking_port)
    with pytest.raises(TypeError, match=r"lacks read\(\)"):
        BNO055UartTransport(object())
    with pytest.raises(ValueError, match="attempts"):
        BNO055UartTransport(FakeBNO055Serial(), attempts=0)
