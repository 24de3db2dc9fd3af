"""BNO055 driver over I2C and UART against the chip emulator: identification, mode switching
with the datasheet's delays, units, axis remap, readings and calibration save/restore."""
import itertools

import numpy as np
import pytest

from sensor.drivers import (BNO055I2C, BNO055UART, AxisRemap, BusError, CalibrationProfile,
                            CalibrationStatus, ChipIdError, DeviceError,
                            OperationMode, ProtocolError, UnitSelection)
from sensor.drivers.bno055_types import PLACEMENTS
from sensor.emulators import BNO055Chip, FakeBNO055Serial, FakeClock, FakeSMBus

G = 9.80665


def quaternion_matrix(q):
    w, x, y, z = np.asarray(q) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def connect(transport, chip=None, clock=None, sleep=None):
    clock = clock or FakeClock()
    chip = chip or BNO055Chip(clock=clock.monotonic)
    sleep = sleep or clock.sleep
    if transport == "i2c":
        imu = BNO055I2C(FakeSMBus({0x28: chip}), sleep=sleep, clock=clock.monotonic)
    else:
        imu = BNO055UART(FakeBNO055Serial(chip, clock=clock), sleep=sleep, clock=clock.monotonic)
    return imu, chip, clock


@pytest.fixture(params=["i2c", "uart"])
def transport(request):
    return request.param


# -- value types ---------------------------------------------------------------------------------

def test_unit_selection_bits_follow_the_datasheet():
    units = UnitSelection("mg", "rad/s", "rad", "F", android_orientation=True)
    assert units.to_byte() == 0b1001_0111
    assert UnitSelection().to_byte() == 0b0000_0110  # m/s^2, rad/s, rad, Celsius, Windows
    for value in (a | g << 1 | e << 2 | t << 4 | o << 7
                  for a, g, e, t, o in itertools.product((0, 1), repeat=5)):
        assert UnitSelection.from_byte(value).to_byte() == value
    with pytest.raises(ValueError, match="acceleration"):
        UnitSelection(acceleration="g")


def test_datasheet_placements_are_proper_rotations():
    assert AxisRemap.placement("P1") == AxisRemap()
    assert AxisRemap().to_bytes() == (0x24, 0x00)
    for name, registers in PLACEMENTS.items():
        remap = AxisRemap.placement(name)
        m = remap.matrix()
        assert remap.to_bytes() == registers
        assert m @ m.T == pytest.approx(np.eye(3))
        assert np.linalg.det(m) == pytest.approx(1.0), name


@pytest.mark.parametrize("axes, signs", [(("x", "x", "z"), (1, 1, 1)), (("x", "y", "z"), (1, 0, 1))])
def test_invalid_axis_remap_is_a_value_error(axes, signs):
    with pytest.raises(ValueError, match="AxisRemap"):
        AxisRemap(axes, signs)


def test_calibration_status_and_profile_encodings():
    assert CalibrationStatus.from_byte(0b11_10_01_00) == CalibrationStatus(3, 2, 1, 0)
    assert not CalibrationStatus.from_byte(0b11_10_01_00).fully_calibrated
    assert CalibrationStatus.from_byte(0xFF).fully_calibrated
    profile = CalibrationProfile((-2, 300, 0), (1, 2, 3), (4, 5, -6), 1000, 480)
    raw = profile.to_bytes()
    assert len(raw) == 22 and raw[:2] == bytes([0xFE, 0xFF]) and raw[2:4] == bytes([0x2C, 0x01])
    assert raw[18:20] == (1000).to_bytes(2, "little")
    assert CalibrationProfile.from_hex(profile.to_hex()) == profile
    with pytest.raises(ValueError, match="22 bytes"):
        CalibrationProfile.from_bytes(raw[:21])
    with pytest.raises(ValueError, match="hex"):
        CalibrationProfile.from_hex("zz")
    with pytest.raises(ValueError, match="16-bit"):
        CalibrationProfile((40000, 0, 0), (0, 0, 0), (0, 0, 0), 0, 0)
    with pytest.raises(ValueError, match="16-bit"):
        CalibrationProfile((1.5, 0, 0), (0, 0, 0), (0, 0, 0), 0, 0)


# -- against the emulated chip ---------------------------------------------------------------

def test_construction_reads_mode_and_units_without_changing_them(transport):
    imu, chip, _ = connect(transport)
    assert imu.mode == OperationMode.CONFIG
    assert imu.units == UnitSelection.from_byte(0x80)
    assert chip.mode == 0


def test_wrong_chip_id_names_the_device_and_values(transport):
    with pytest.raises(ChipIdError, match=r"BNO055.*0x42 read, expected 0xA0"):
        connect(transport, chip=BNO055Chip(chip_id=0x42))


def test_mode_switches_wait_the_datasheet_delays(transport):
    imu, chip, clock = connect(transport)
    start = clock.now
    imu.set_mode(OperationMode.NDOF)
    assert clock.now - start >= 0.007
    assert imu.quaternion() == pytest.approx((1.0, 0.0, 0.0, 0.0))  # the chip answers again
    start = clock.now
    imu.set_mode(OperationMode.CONFIG)
    assert clock.now - start >= 0.019
    assert chip.mode == 0 and imu.mode == OperationMode.CONFIG
    if transport == "uart":
        assert imu.link_stats.timeouts == 0  # no request hit the busy chip


def test_without_the_delay_the_chip_does_not_answer():
    # Negative controls for the test above: a driver that does not wait hits the busy chip.
    imu, _, _ = connect("i2c", sleep=lambda s: None)
    imu.set_mode(OperationMode.NDOF)
    with pytest.raises(BusError, match="Remote I/O error"):
        imu.calibration_status()
    imu, _, _ = connect("uart", sleep=lambda s: None)
    imu.set_mode(OperationMode.NDOF)
    imu.calibration_status()  # over UART the reply timeout outlasts the switch ...
    assert imu.link_stats.timeouts >= 1  # ... but only after a request went unanswered


def test_readings_are_si_in_either_acceleration_unit(transport):
    imu, chip, _ = connect(transport)
    q = np.array([0.9, -0.1, 0.3, 0.2]) / np.linalg.norm([0.9, -0.1, 0.3, 0.2])
    chip.quat_wxyz, chip.lin_acc_mps2 = q, np.array([0.25, -1.5, 3.0])
    chip.gravity_mps2 = quaternion_matrix(q).T @ np.array([0.0, 0.0, G])
    chip.calibration_status = (2, 3, 1, 0)
    for units, tolerance in ((UnitSelection(acceleration="m/s^2"), 0.005),
                             (UnitSelection(acceleration="mg"), 0.005)):
        imu.set_units(units)
        imu.set_mode(OperationMode.IMU)
        assert imu.quaternion() == pytest.approx(tuple(q), abs=1e-4)
        assert imu.linear_acceleration() == pytest.approx(chip.lin_acc_mps2, abs=tolerance)
        assert imu.gravity() == pytest.approx(chip.gravity_mps2, abs=tolerance)
        sample = imu.fusion_sample()
        assert sample.quat_wxyz == pytest.approx(q, abs=1e-4)
        assert sample.gravity_mps2 == pytest.approx(chip.gravity_mps2, abs=tolerance)
        assert imu.calibration_status() == CalibrationStatus(2, 3, 1, 0)
        imu.set_mode(OperationMode.CONFIG)
    assert chip.pages[0][0x3B] == UnitSelection(acceleration="mg").to_byte()


def test_fusion_readings_outside_a_fusion_mode_are_refused(transport):
    imu, _, _ = connect(transport)
    with pytest.raises(DeviceError, match="needs a fusion mode.*CONFIG"):
        imu.quaternion()
    imu.set_mode(OperationMode.AMG)
    with pytest.raises(DeviceError, match="AMG"):
        imu.fusion_sample()


def test_axis_remap_reaches_the_chip_and_keeps_world_gravity(transport):
    imu, chip, _ = connect(transport)
    q = np.array([0.8, 0.3, -0.2, 0.45]) / np.linalg.norm([0.8, 0.3, -0.2, 0.45])
    chip.quat_wxyz = q
    chip.gravity_mps2 = quaternion_matrix(q).T @ np.array([0.0, 0.0, G])
    remap = AxisRemap.placement("P6")
    imu.set_axis_remap(remap)
    assert imu.axis_remap() == remap
    assert bytes(chip.pages[0][0x41:0x43]) == bytes(PLACEMENTS["P6"])
    imu.set_mode(OperationMode.NDOF)
    sample = imu.fusion_sample()
    assert sample.gravity_mps2 == pytest.approx(remap.matrix() @ chip.gravity_mps2, abs=0.01)
    # whatever the sensor frame, its orientation must carry measured gravity to world down-up
    assert quaternion_matrix(sample.quat_wxyz) @ sample.gravity_mps2 == pytest.approx([0, 0, G], abs=0.02)


def test_calibration_profile_survives_a_reset_by_save_and_restore(transport):
    imu, chip, clock = connect(transport)
    imu.set_mode(OperationMode.NDOF)
    saved = CalibrationProfile((-25, 13, 40), (120, -300, 77), (-2, 1, 0), 1000, 682)
    imu.write_calibration(saved)
    assert chip.calibration_bytes == saved.to_bytes()
    assert imu.mode == OperationMode.NDOF and chip.mode == OperationMode.NDOF
    profile_hex = imu.read_calibration().to_hex()
    start = clock.now
    imu.reset()
    assert clock.now - start >= 0.65
    assert chip.resets == 1 and imu.mode == OperationMode.CONFIG
    assert imu.read_calibration() == CalibrationProfile.from_bytes(bytes(22))  # lost on reset
    imu.write_calibration(CalibrationProfile.from_hex(profile_hex))
    assert imu.read_calibration() == saved


def test_page_selection_is_cached_and_validated(transport):
    imu, chip, _ = connect(transport)
    imu.select_page(1)
    assert chip.page == 1
    imu.calibration_status()  # switches back to page 0 for data registers
    assert chip.page == 0
    with pytest.raises(ValueError, match="page"):
        imu.select_page(2)


def test_unknown_mode_is_a_value_error(transport):
    imu, _, _ = connect(transport)
    with pytest.raises(ValueError, match="operation mode"):
        imu.set_mode(0x0D)


def test_register_write_outside_config_mode_is_named_over_uart():
    imu, _, _ = connect("uart")
    imu.set_mode(OperationMode.NDOF)
    with pytest.raises(ProtocolError, match=r"REGMAP_WRITE_DISABLED.*ACC_OFFSET_X_LSB"):
        imu.transport.write(0x55, bytes(22))


def test_refused_write_over_i2c_is_caught_by_the_readback():
    # Over I2C the chip acknowledges and ignores a refused write; the driver's read-back catches it.
    imu, chip, _ = connect("i2c")
    imu.set_mode(OperationMode.NDOF)
    imu.mode = OperationMode.CONFIG  # the driver believes it is in CONFIG mode: it is not
    with pytest.raises(DeviceError, match="UNIT_SEL not accepted"):
        imu.set_units(UnitSelection(acceleration="mg"))
