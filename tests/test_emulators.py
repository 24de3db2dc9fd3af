"""The chip and port emulators behave like the datasheets say, independently of the drivers."""
import struct
import subprocess
import sys

import numpy as np
import pytest

from sensor.drivers import BMP280, BMP280RegisterSettings, IIRFilter, Oversampling
from sensor.drivers.bmp280_compensation import DATASHEET_EXAMPLE_CALIBRATION as EXAMPLE
from sensor.emulators import (BMP280Chip, BNO055Chip, FakeBNO055Serial, FakeClock, FakeSMBus,
                              Fault, FaultInjector, register_serial_url_handlers)
from sensor.emulators.bmp280_chip import (fine_temperature_int32, pressure_q24_8_int64,
                                          raw_pressure_for, raw_temperature_for,
                                          temperature_centi_c)
from sensor.emulators.bno055_chip import WriteResult
from sensor.emulators.fake_smbus import ChipBusy

G = 9.80665


def raw20(registers, start):
    return (registers[start] << 12) | (registers[start + 1] << 4) | (registers[start + 2] >> 4)


# -- BMP280 --------------------------------------------------------------------------------------

def test_integer_compensation_reproduces_the_datasheet_worked_example():
    t_fine = fine_temperature_int32(519888, EXAMPLE)
    assert t_fine == 128422
    assert temperature_centi_c(t_fine) == 2508
    assert pressure_q24_8_int64(415148, t_fine, EXAMPLE) / 256 == pytest.approx(100653.27, abs=0.05)


@pytest.mark.parametrize("temperature_c, pressure_pa", [(-20.0, 80_000.0), (25.0, 101_325.0),
                                                        (60.0, 110_000.0)])
def test_raw_values_invert_the_integer_compensation(temperature_c, pressure_pa):
    adc_t = raw_temperature_for(temperature_c, EXAMPLE)
    t_fine = fine_temperature_int32(adc_t, EXAMPLE)
    assert t_fine / 5120 == pytest.approx(temperature_c, abs=0.003)  # ~0.005 C per LSB
    adc_p = raw_pressure_for(pressure_pa, t_fine, EXAMPLE)
    assert pressure_q24_8_int64(adc_p, t_fine, EXAMPLE) / 256 == pytest.approx(pressure_pa, abs=0.15)
    assert 0 < adc_p < (1 << 20) and 0 < adc_t < (1 << 20)


def test_pressure_resolution_follows_oversampling_without_filter():
    chip = BMP280Chip(pressure_pa=100_001.3)
    chip.write_block(0xF4, bytes([0b001_001_11]))  # x1 / x1, normal: 16-bit pressure
    chip.read_block(0xF7, 6)
    assert raw20(chip.registers, 0xF7) & 0xF == 0
    chip.write_block(0xF5, bytes([0b000_001_00]))  # IIR filter on: full 20 bits
    values = set()
    for true_pa in np.linspace(100_000, 100_003, 7):
        chip.pressure_pa = true_pa
        chip.read_block(0xF7, 6)
        values.add(raw20(chip.registers, 0xF7) & 0xF)
    assert values != {0}


def test_skipped_channel_reads_0x80000():
    chip = BMP280Chip()
    chip.write_block(0xF4, bytes([0b001_000_11]))  # pressure skipped, normal mode
    chip.read_block(0xF7, 6)
    assert raw20(chip.registers, 0xF7) == 0x80000
    assert raw20(chip.registers, 0xFA) != 0x80000


def test_soft_reset_needs_the_magic_value():
    chip = BMP280Chip()
    chip.write_block(0xF4, bytes([0x27]))
    chip.write_block(0xE0, bytes([0xB5]))
    assert chip.registers[0xF4] == 0x27
    chip.write_block(0xE0, bytes([0xB6]))
    assert chip.registers[0xF4] == 0x00
    assert chip.read_block(0xF3, 1)[0] & 0x01  # im_update while the NVM is copied


@pytest.mark.parametrize("iir, samples_to_75_percent", [
    (IIRFilter.OFF, 1), (IIRFilter.X2, 2), (IIRFilter.X4, 5), (IIRFilter.X8, 11), (IIRFilter.X16, 22)])
def test_iir_step_response_matches_datasheet_table_6(iir, samples_to_75_percent):
    chip = BMP280Chip(pressure_pa=100_000.0)
    clock = FakeClock()
    barometer = BMP280(FakeSMBus({0x76: chip}), sleep=clock.sleep, clock=clock.monotonic,
                       config=BMP280RegisterSettings(Oversampling.X16, Oversampling.X2, iir_filter=iir))
    before = barometer.read()[0]
    chip.pressure_pa = 102_000.0
    fractions = [(barometer.read()[0] - before) / 2000.0 for _ in range(30)]
    # x2 reaches exactly 75 % after two samples; allow 0.1 % for ADC quantisation
    assert next(i for i, f in enumerate(fractions, 1) if f >= 0.749) == samples_to_75_percent
    barometer.configure(barometer.config)  # writing config resets the filter
    chip.pressure_pa = 98_000.0
    assert barometer.read()[0] == pytest.approx(98_000.0, abs=1.0)  # filtered: 250 Pa off at x16


# -- BNO055 --------------------------------------------------------------------------------------

def ndof_chip(**options):
    chip = BNO055Chip(**options)
    assert chip.write_block(0x3D, bytes([0x0C])) == WriteResult.OK
    return chip


def test_quaternion_registers_hold_int16_lsb_first_at_2_14_per_unit():
    chip = ndof_chip()
    chip.quat_wxyz = np.array([0.5, 0.5, -0.5, 0.5])
    assert chip.read_block(0x20, 8) == struct.pack("<4h", 8192, 8192, -8192, 8192)
    assert chip.read_block(0x20, 8)[:2] == bytes([0x00, 0x20])


def test_acceleration_outputs_follow_unit_selection():
    chip = ndof_chip()
    chip.gravity_mps2 = np.array([0.0, 0.0, G])
    chip.lin_acc_mps2 = np.array([1.0, -2.0, 0.5])
    assert struct.unpack("<3h", chip.read_block(0x2E, 6)) == (0, 0, 981)  # 100 LSB per m/s^2
    assert struct.unpack("<3h", chip.read_block(0x28, 6)) == (100, -200, 50)
    chip.write_block(0x3D, bytes([0x00]))
    chip.write_block(0x3B, bytes([0x01]))  # acceleration in mg
    chip.write_block(0x3D, bytes([0x0C]))
    assert struct.unpack("<3h", chip.read_block(0x2E, 6)) == (0, 0, 1000)  # 1 LSB per mg


@pytest.mark.parametrize("mode, status", [(0x00, 0), (0x07, 6), (0x08, 5), (0x0C, 5)])
def test_fusion_outputs_exist_only_in_fusion_modes(mode, status):
    chip = BNO055Chip()
    chip.quat_wxyz = np.array([0.0, 1.0, 0.0, 0.0])
    chip.write_block(0x3D, bytes([mode]))
    fused = any(chip.read_block(0x20, 20))
    assert fused == (mode >= 0x08)
    assert chip.read_block(0x39, 1)[0] == status  # SYS_STATUS: idle / no fusion / fusion


def test_configuration_registers_are_writable_only_in_config_mode():
    chip = ndof_chip()
    profile = bytes(range(1, 23))
    assert chip.write_block(0x55, profile) == WriteResult.WRITE_DISABLED
    assert chip.calibration_bytes == bytes(22)
    assert chip.write_block(0x3B, bytes([0x01])) == WriteResult.WRITE_DISABLED
    assert chip.write_block(0x00, bytes([0x12])) == WriteResult.INVALID_ADDRESS  # read-only
    assert chip.write_block(0x3D, bytes([0x00])) == WriteResult.OK  # OPR_MODE: any mode
    assert chip.write_block(0x55, profile) == WriteResult.OK
    assert chip.calibration_bytes == profile


def test_invalid_axis_map_keeps_the_previous_one():
    chip = BNO055Chip()
    chip.write_block(0x41, bytes([0x21]))  # swap x and y: valid
    chip.write_block(0x41, bytes([0x25]))  # x and y both from device y: invalid
    assert chip.read_block(0x41, 1)[0] == 0x21


def test_axis_remap_applies_to_vectors_and_orientation():
    chip = BNO055Chip()
    chip.write_block(0x41, bytes([0x21, 0x04]))  # placement P0: x' = -y, y' = x
    chip.write_block(0x3D, bytes([0x0C]))
    chip.gravity_mps2 = np.array([1.0, 2.0, 9.0])
    assert struct.unpack("<3h", chip.read_block(0x2E, 6)) == (-200, 100, 900)
    chip.quat_wxyz = np.array([1.0, 0.0, 0.0, 0.0])
    w, x, y, z = np.array(struct.unpack("<4h", chip.read_block(0x20, 8))) / 16384
    # the remapped frame is the device frame turned -90 deg about z
    assert (w, x, y, z) == pytest.approx((np.sqrt(0.5), 0.0, 0.0, -np.sqrt(0.5)), abs=1e-4)


def test_mode_switch_and_reset_make_the_chip_unresponsive_for_the_datasheet_times():
    clock = FakeClock()
    chip = BNO055Chip(clock=clock.monotonic)
    chip.write_block(0x3D, bytes([0x0C]))
    clock.advance(0.0069)
    with pytest.raises(ChipBusy):
        chip.read_block(0x00, 1)
    clock.advance(0.0002)
    assert chip.read_block(0x00, 1) == bytes([0xA0])
    chip.write_block(0x3D, bytes([0x00]))
    clock.advance(0.0185)
    with pytest.raises(ChipBusy):
        chip.read_block(0x00, 1)
    clock.advance(0.001)
    chip.write_block(0x55, bytes(range(22)))
    chip.write_block(0x3F, bytes([0x20]))
    clock.advance(0.64)
    with pytest.raises(ChipBusy):
        chip.read_block(0x00, 1)
    clock.advance(0.02)
    assert chip.calibration_bytes == bytes(22)  # a reset loses the calibration
    assert chip.resets == 1


# -- UART port --------------------------------------------------------------------------------

@pytest.mark.parametrize("request_bytes, reply", [
    (bytes([0xAA, 0x01, 0x00, 0x01]), bytes([0xBB, 0x01, 0xA0])),  # read CHIP_ID
    (bytes([0xAA, 0x00, 0x3D, 0x01, 0x0C]), bytes([0xEE, 0x01])),  # write OPR_MODE: WRITE_SUCCESS
    (bytes([0xAA, 0x00, 0x00, 0x01, 0x00]), bytes([0xEE, 0x04])),  # read-only: INVALID_ADDRESS
    (bytes([0xAA, 0x01, 0x00, 0x00]), bytes([0xEE, 0x09])),  # MIN_LENGTH_ERROR
    (bytes([0xAA, 0x01, 0x00, 0xC8]), bytes([0xEE, 0x08])),  # MAX_LENGTH_ERROR (200 > 128)
    (bytes([0x55]), bytes([0xEE, 0x06])),  # WRONG_START_BYTE
])
def test_uart_port_answers_datasheet_frames(request_bytes, reply):
    port = FakeBNO055Serial()
    port.write(request_bytes)
    assert port.read(64) == reply


def test_uart_write_disabled_outside_config_and_split_frames():
    port = FakeBNO055Serial()
    port.write(bytes([0xAA, 0x00, 0x3D]))
    assert port.in_waiting == 0  # incomplete frame: no answer yet
    port.write(bytes([0x01, 0x0C]))
    assert port.read(2) == bytes([0xEE, 0x01])
    port.write(bytes([0xAA, 0x00, 0x55, 0x02, 0x01, 0x02]))
    assert port.read(2) == bytes([0xEE, 0x05])  # REGMAP_WRITE_DISABLED


def test_fault_injector_targets_registers_counts_and_heals():
    faults = FaultInjector()
    faults.inject(Fault.NACK, times=2, register=0x20)
    assert faults.take(0x3D) is None
    assert [faults.take(0x20) for _ in range(3)] == [Fault.NACK, Fault.NACK, None]
    faults.inject(Fault.DISCONNECT)
    assert faults.take(0x00) is Fault.DISCONNECT and faults.take(0x01) is Fault.DISCONNECT
    assert faults.triggered[Fault.NACK] == 2 and faults.triggered[Fault.DISCONNECT] == 2
    faults.clear()
    assert faults.take(0x00) is None
    with pytest.raises(ValueError, match="times"):
        faults.inject(Fault.NACK, times=0)


def test_pyserial_url_handlers_open_working_emulated_ports():
    serial = pytest.importorskip("serial")
    from sensor.drivers import BNO055UART, MicrocontrollerStream, OperationMode
    register_serial_url_handlers()
    register_serial_url_handlers()  # idempotent
    assert serial.protocol_handler_packages.count("sensor.emulators") == 1
    port = serial.serial_for_url("bno055emu://", timeout=0.01)
    port.emulator.chip.quat_wxyz = np.array([0.0, 0.0, 1.0, 0.0])
    imu = BNO055UART(port, sleep=lambda s: None)
    imu.set_mode(OperationMode.IMU)
    assert imu.quaternion() == pytest.approx((0.0, 0.0, 1.0, 0.0))
    port.emulator.faults.inject(Fault.DISCONNECT)
    with pytest.raises(serial.SerialException):
        port.write(b"\xAA\x01\x00\x01")
    stream_port = serial.serial_for_url("mcuemu://", timeout=0.01)
    stream_port.emulator.queue_sample(5, 100_100.0)
    assert MicrocontrollerStream(stream_port).poll()[0].pressure_pa == pytest.approx(100_100.0)
    with pytest.raises(serial.SerialException, match="bno055emu://"):
        serial.serial_for_url("bno055emu://?baud=9", timeout=0.01)


def test_packages_import_neither_smbus2_nor_pyserial():
    code = ("import sys, sensor.drivers, sensor.emulators; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('serial', 'smbus2')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
