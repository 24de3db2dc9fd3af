"""BMP280 driver: compensation against the datasheet's worked example, register protocol and
configuration against the datasheet's tables, end to end against the chip emulator."""
import struct

import pytest

from sensor.drivers import (BMP280, BMP280Calibration, BMP280RegisterSettings, BusError, ChipIdError,
                            DeviceTimeoutError, IIRFilter, Oversampling, PowerMode, Standby)
from sensor.drivers.bmp280_compensation import (DATASHEET_EXAMPLE_CALIBRATION,
                                                compensate_pressure, compensate_temperature)
from sensor.emulators import BMP280Chip, FakeClock, FakeSMBus
from sensor.emulators.bmp280_chip import fine_temperature_int32, pressure_q24_8_int64


def make_barometer(chip=None, address=0x76, **options):
    chip = chip or BMP280Chip()
    bus = FakeSMBus({address: chip})
    clock = FakeClock()
    barometer = BMP280(bus, address, sleep=clock.sleep, clock=clock.monotonic, **options)
    return barometer, chip, bus, clock


# -- compensation ------------------------------------------------------------------------------

def test_compensation_reproduces_the_datasheet_worked_example():
    # BMP280 datasheet section 3.12: adc_T = 519888, adc_P = 415148 with the example trimming
    # -> t_fine = 128422.2869948, T = 25.08 C, p = 100653.27 Pa.
    temperature_c, t_fine = compensate_temperature(519888, DATASHEET_EXAMPLE_CALIBRATION)
    assert temperature_c == pytest.approx(25.08, abs=0.005)
    assert t_fine == pytest.approx(128422.2869948, abs=0.01)
    pressure_pa = compensate_pressure(415148, t_fine, DATASHEET_EXAMPLE_CALIBRATION)
    assert pressure_pa == pytest.approx(100653.27, abs=0.01)


def test_floating_point_compensation_agrees_with_the_datasheet_integer_variant():
    # Two code paths from the datasheet (double here, 32/64-bit integer in the emulator) must
    # agree to within the integer variant's resolution over the sensor's whole range.
    cal = DATASHEET_EXAMPLE_CALIBRATION
    for adc_t in range(420_000, 620_001, 20_000):
        temperature_c, t_fine = compensate_temperature(adc_t, cal)
        # t_fine counts 1/5120 C; the integer shifts round down at three places
        assert t_fine == pytest.approx(fine_temperature_int32(adc_t, cal), abs=3.0)
        for adc_p in range(250_000, 600_001, 50_000):
            pressure_pa = compensate_pressure(adc_p, t_fine, cal)
            reference = pressure_q24_8_int64(adc_p, fine_temperature_int32(adc_t, cal), cal) / 256
            assert pressure_pa == pytest.approx(reference, abs=0.5)


def test_calibration_decodes_little_endian_signed_and_unsigned_words():
    words = [27504, 26435, -1000, 36477, -10685, 3024, 2855, 140, -7, 15500, -14600, 6000]
    raw = b"".join(struct.pack("<H" if i in (0, 3) else "<h", w) for i, w in enumerate(words))
    assert raw[:2] == bytes([0x70, 0x6B])  # dig_T1 = 0x6B70, LSB first
    assert BMP280Calibration.from_bytes(raw) == DATASHEET_EXAMPLE_CALIBRATION
    assert DATASHEET_EXAMPLE_CALIBRATION.to_bytes() == raw


@pytest.mark.parametrize("raw, problem", [(bytes(23), "24 bytes"), (bytes(24), "dig_P1 == 0")])
def test_bad_calibration_bytes_are_rejected(raw, problem):
    with pytest.raises(ValueError, match=problem):
        BMP280Calibration.from_bytes(raw)


# -- configuration ------------------------------------------------------------------------------

def test_register_values_follow_the_datasheet_bit_layout():
    config = BMP280RegisterSettings(Oversampling.X16, Oversampling.X2, IIRFilter.X16, Standby.MS_0_5,
                          PowerMode.NORMAL)
    assert config.ctrl_meas() == 0b010_101_11  # osrs_t x2, osrs_p x16, normal
    assert config.config_register() == 0b000_100_00  # t_sb 0.5 ms, filter 16
    forced = BMP280RegisterSettings(Oversampling.X1, Oversampling.X1, IIRFilter.OFF, Standby.MS_4000,
                          PowerMode.FORCED)
    assert forced.ctrl_meas() == 0b001_001_01
    assert forced.config_register() == 0b111_000_00


@pytest.mark.parametrize("pressure, temperature, standby, rate_hz", [
    (Oversampling.X4, Oversampling.X1, Standby.MS_0_5, 83.3),  # handheld device dynamic
    (Oversampling.X16, Oversampling.X2, Standby.MS_0_5, 26.3),  # indoor navigation
    (Oversampling.X4, Oversampling.X1, Standby.MS_125, 7.3),  # elevator / floor change
    (Oversampling.X2, Oversampling.X1, Standby.MS_0_5, 125.0),  # drop detection
])
def test_output_data_rate_matches_datasheet_table_7(pressure, temperature, standby, rate_hz):
    config = BMP280RegisterSettings(pressure, temperature, standby=standby)
    assert config.output_data_rate_hz() == pytest.approx(rate_hz, abs=0.05)


@pytest.mark.parametrize("pressure, temperature, max_ms", [
    (Oversampling.X1, Oversampling.X1, 6.4), (Oversampling.X2, Oversampling.X1, 8.7),
    (Oversampling.X4, Oversampling.X1, 13.3), (Oversampling.X8, Oversampling.X1, 22.5),
    (Oversampling.X16, Oversampling.X2, 43.2)])
def test_maximum_measurement_time_matches_datasheet_table_13(pressure, temperature, max_ms):
    config = BMP280RegisterSettings(pressure, temperature)
    assert config.measurement_time_s() * 1e3 == pytest.approx(max_ms, abs=0.05)


@pytest.mark.parametrize("options, problem", [
    ({"pressure_oversampling": 9}, "pressure_oversampling=9"),
    ({"iir_filter": "strong"}, "iir_filter"),
    ({"temperature_oversampling": Oversampling.SKIPPED}, "SKIPPED"),
])
def test_invalid_configuration_is_a_value_error(options, problem):
    with pytest.raises(ValueError, match=problem):
        BMP280RegisterSettings(**options)


# -- against the emulated chip -------------------------------------------------------------------

@pytest.mark.parametrize("oversampling, tolerance_pa", [(Oversampling.X1, 2.7), (Oversampling.X16, 0.2)])
def test_reads_true_pressure_and_temperature_within_the_resolution(oversampling, tolerance_pa):
    chip = BMP280Chip(pressure_pa=99_876.5, temperature_c=31.7)
    barometer, *_ = make_barometer(chip, config=BMP280RegisterSettings(pressure_oversampling=oversampling))
    for true_pa in (95_000.0, 99_876.5, 104_321.0):
        chip.pressure_pa = true_pa
        pressure_pa, temperature_c = barometer.read()
        assert pressure_pa == pytest.approx(true_pa, abs=tolerance_pa)
        assert temperature_c == pytest.approx(31.7, abs=0.01)


def test_initialisation_resets_waits_for_nvm_copy_and_writes_configuration():
    chip = BMP280Chip(busy_reads=3)
    config = BMP280RegisterSettings(Oversampling.X8, Oversampling.X2, IIRFilter.X4, Standby.MS_62_5)
    barometer, chip, bus, _ = make_barometer(chip, config=config)
    writes = [entry for entry in bus.log if entry[0] == "write"]
    assert writes[0][2] == 0xE0  # soft reset first
    status_reads = [entry for entry in bus.log if entry[0] == "read" and entry[2] == 0xF3]
    assert len(status_reads) == 4  # im_update seen set three times, then clear
    first_calibration_read = next(i for i, e in enumerate(bus.log) if e[2] == 0x88)
    assert first_calibration_read > bus.log.index(status_reads[-1])
    assert chip.registers[0xF4] == config.ctrl_meas()
    assert chip.registers[0xF5] == config.config_register()


def test_data_is_read_in_one_burst_of_six_bytes():
    barometer, _, bus, _ = make_barometer()
    bus.log.clear()
    barometer.read()
    assert bus.log == [("read", 0x76, 0xF7, 6)]


def test_forced_mode_triggers_a_conversion_and_waits_for_it():
    barometer, chip, bus, clock = make_barometer(config=BMP280RegisterSettings(mode=PowerMode.FORCED))
    chip.pressure_pa = 97_000.0
    before_s, conversions = clock.now, chip.conversions
    pressure_pa, _ = barometer.read()
    assert pressure_pa == pytest.approx(97_000.0, abs=0.7)
    assert chip.conversions == conversions + 1
    assert chip.mode == 0  # back to sleep after the conversion
    assert clock.now - before_s >= barometer.config.measurement_time_s()


def test_sleep_mode_without_conversion_is_a_timeout_naming_the_data_register():
    barometer, *_ = make_barometer(config=BMP280RegisterSettings(mode=PowerMode.SLEEP))
    with pytest.raises(DeviceTimeoutError, match=r"0xF7.*0x80000"):
        barometer.read()


def test_nvm_copy_that_never_finishes_times_out_naming_the_status_register():
    with pytest.raises(DeviceTimeoutError, match=r"BMP280 at I2C 0x76 \(register 0xF3\)"):
        make_barometer(BMP280Chip(busy_reads=10_000))


def test_wrong_chip_id_names_address_and_id_read():
    with pytest.raises(ChipIdError, match=r"0x77.*0x60 read, expected 0x58.*BME280") as info:
        make_barometer(BMP280Chip(chip_id=0x60), address=0x77)
    assert info.value.found == 0x60


def test_absent_chip_is_a_bus_error_naming_the_address():
    bus = FakeSMBus({})
    with pytest.raises(BusError, match=r"BMP280 at I2C 0x76 \(register 0xD0\)"):
        BMP280(bus, sleep=lambda s: None)


def test_bad_address_and_bus_objects_are_rejected():
    with pytest.raises(ValueError, match="address"):
        BMP280(FakeSMBus(), address=0x80)
    with pytest.raises(TypeError, match="read_i2c_block_data"):
        BMP280(object())
