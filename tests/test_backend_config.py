"""Backend configuration: files, validation naming the bad key, opening and closing devices."""
from __future__ import annotations

import contextlib
import json
from pathlib import Path

import numpy as np
import pytest

from explorer.backends import open_backends, open_sensor
from explorer.config import BackendConfig, RobotConfig, SensorConfig, config_from_dict, load_config
from robots.hardware import SerialArm
from sensor.calibration import SensorCalibration
from sensor.drivers import CalibrationProfile, ChipIdError, HardwareTactileSensor
from sensor.emulators import BMP280Chip, BNO055Chip, FakeClock, FakeSMBus

CONFIGS = Path(__file__).resolve().parents[1] / "configs"


def test_toml_and_json_with_the_same_content_give_the_same_config(tmp_path):
    (tmp_path / "a.toml").write_text('[robot]\nbackend = "serial"\nport = "/dev/ttyUSB3"\nattempts = 2\n'
                                     '[sensor]\nbackend = "i2c"\nbus = 3\nbmp280_address = 0x77\n'
                                     'calibration = "cal/c.json"\n')
    (tmp_path / "b.json").write_text(json.dumps({
        "robot": {"backend": "serial", "port": "/dev/ttyUSB3", "attempts": 2},
        "sensor": {"backend": "i2c", "bus": 3, "bmp280_address": "0x77", "calibration": "cal/c.json"}}))
    a, b = load_config(tmp_path / "a.toml"), load_config(tmp_path / "b.json")
    assert (a.robot, a.sensor) == (b.robot, b.sensor)
    assert a.sensor.bmp280_address == 0x77 and a.robot.attempts == 2
    assert a.sensor.calibration == tmp_path / "cal" / "c.json"  # relative to the file
    assert a.source == tmp_path / "a.toml"


def test_missing_sections_and_keys_take_the_defaults():
    config = config_from_dict({})
    assert config.robot == RobotConfig() and config.sensor == SensorConfig()
    assert config.robot.backend == "sim" and config.sensor.bno055_address == 0x28


def test_baud_rate_defaults_depend_on_the_sensor_link():
    assert SensorConfig(backend="uart", port="/dev/ttyUSB1").baudrate == 115200
    assert SensorConfig(backend="mcu", port="/dev/ttyACM0").baudrate == 230400


@pytest.mark.parametrize("name", sorted(p.name for p in CONFIGS.glob("*.*") if p.suffix in (".toml", ".json")))
def test_every_example_config_loads(name):
    config = load_config(CONFIGS / name)
    assert isinstance(config, BackendConfig)
    assert config.robot.backend in ("sim", "serial", "emulated")
    assert config.exploration.touches >= 1 and config.object.name


@pytest.mark.parametrize("data, message", [
    ({"robot": {"prot": "/dev/ttyUSB0"}}, r"robot\.prot: unknown key \(did you mean 'port'\?\)"),
    ({"robots": {}}, r"robots: unknown key \(did you mean 'robot'\?\)"),
    ({"robot": {"backend": "ros"}}, r"robot\.backend: 'ros' is not one of 'sim', 'serial', 'emulated'"),
    ({"robot": {"backend": "emulated"}, "sensor": {"backend": "i2c"}},
     r"sensor\.backend: robot\.backend = 'emulated' needs sensor\.backend = 'emulated'"),
    ({"object": {"centre_m": [0.1, 0.2]}}, r"object\.centre_m: expected three numbers"),
    ({"object": {"half_extent_m": [0.1, 0.0, 0.1]}}, r"object\.half_extent_m: every component must be positive"),
    ({"object": {"name": ""}}, r"object\.name: expected a non-empty name"),
    ({"exploration": {"touches": 0}}, r"exploration\.touches: 0 must be >= 1"),
    ({"exploration": {"strategy": "greedy"}}, r"exploration\.strategy: 'greedy' is not one of"),
    ({"exploration": {"use_normals": "yes"}}, r"exploration\.use_normals: expected true or false"),
    ({"exploration": {"reach_samples": -1}}, r"exploration\.reach_samples: -1 must be >= 0"),
    ({"exploration": {"touchs": 5}}, r"exploration\.touchs: unknown key \(did you mean 'touches'\?\)"),
    ({"emulation": {"sphere_radius_m": 0}}, r"emulation\.sphere_radius_m: expected a positive number"),
    ({"robot": {"backend": "serial"}}, r"robot\.port: required when robot\.backend = 'serial'"),
    ({"robot": {"attempts": 0}}, r"robot\.attempts: 0 must be in 1\.\.100"),
    ({"robot": {"attempts": True}}, r"robot\.attempts: expected an integer"),
    ({"robot": {"control_rate_hz": "fast"}}, r"robot\.control_rate_hz: expected a positive number"),
    ({"robot": {"reply_timeout_s": -1}}, r"robot\.reply_timeout_s: expected a positive number"),
    ({"robot": {"spec": ""}}, r"robot\.spec"),
    ({"robot": {"obstacles_m": [0.4, -0.3, 0.37, 0.3, 0.4, 0.37]}}, r"robot\.obstacles_m\[0\]: expected six numbers"),
    ({"robot": {"obstacles_m": [[0.4, -0.3, 0.37, 0.3, 0.0, 0.37]]}}, r"robot\.obstacles_m\[0\]: the half sizes"),
    ({"robot": {"obstacles_m": "table"}}, r"robot\.obstacles_m: expected a list of boxes"),
    ({"robot": []}, r"robot: must be a table"),
    ({"sensor": {"backend": "spi"}}, r"sensor\.backend: 'spi' is not one of"),
    ({"sensor": {"bmp280_address": 0x99}}, r"sensor\.bmp280_address: 153 must be in 0\.\.127"),
    ({"sensor": {"bmp280_address": 0x28}}, r"sensor\.bmp280_address: 0x28 is not a possible address.*SDO"),
    ({"sensor": {"bno055_address": "0xZZ"}}, r"sensor\.bno055_address: '0xZZ' is not a hexadecimal"),
    ({"sensor": {"bus": -1}}, r"sensor\.bus: -1 must be >= 0"),
    ({"sensor": {"backend": "uart"}}, r"sensor\.port: required when sensor\.backend = 'uart'"),
    ({"sensor": {"backend": "mcu", "port": ""}}, r"sensor\.port: expected a device path"),
    ({"sensor": {"imu_mode": "CONFIG"}}, r"sensor\.imu_mode: 'CONFIG' is not one of"),
    ({"sensor": {"calibration": 5}}, r"sensor\.calibration: expected a file path"),
    ([1, 2], r"must be a table/object"),
])
def test_invalid_configs_name_the_bad_key(data, message):
    with pytest.raises(ValueError, match=message):
        config_from_dict(data)


def test_file_errors_name_the_file(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[robot\n")
    with pytest.raises(ValueError, match=r"bad\.toml is not valid TOML"):
        load_config(bad)
    wrong = tmp_path / "wrong.toml"
    wrong.write_text('[sensor]\nbus = "one"\n')
    with pytest.raises(ValueError, match=r"wrong\.toml: sensor\.bus: expected an integer"):
        load_config(wrong)
    (tmp_path / "c.yaml").write_text("robot: {}")
    with pytest.raises(ValueError, match=r"must end in \.toml or \.json"):
        load_config(tmp_path / "c.yaml")
    with pytest.raises(FileNotFoundError, match="nowhere.toml"):
        load_config(tmp_path / "nowhere.toml")


# ---- opening ---------------------------------------------------------------------------------

def test_open_backends_opens_and_closes_the_emulated_arm_and_sensor():
    pytest.importorskip("serial")
    config = load_config(CONFIGS / "emulated.toml")
    with open_backends(config) as (robot, sensor):
        assert isinstance(robot, SerialArm) and isinstance(sensor, HardwareTactileSensor)
        q = robot.joint_positions()
        np.testing.assert_allclose(q, robot.spec.home_q, atol=1e-4)
        reading = sensor.read()
        assert 90_000 < reading.pressure_pa < 110_000
        port = robot.joints._port
    assert not robot.joints.is_open and not port.is_open
    assert not sensor.is_open


def test_open_sensor_over_i2c_reads_the_chips_applies_the_bno055_profile_and_closes_the_bus(tmp_path):
    clock = FakeClock()
    imu_chip = BNO055Chip(clock=clock.monotonic)
    imu_chip.quat_wxyz = np.array([0.8, 0.6, 0.0, 0.0])
    bus = FakeSMBus({0x77: BMP280Chip(pressure_pa=99_000.0), 0x29: imu_chip})
    profile = CalibrationProfile((-12, 7, 30), (210, -95, 400), (-1, 2, 0), 1000, 730)
    SensorCalibration(bno055_profile_hex=profile.to_hex()).save(tmp_path / "cal.json")
    config = SensorConfig(backend="i2c", bus=4, bmp280_address=0x77, bno055_address=0x29,
                          calibration=tmp_path / "cal.json")
    opened = []
    with open_sensor(config, clock=clock.monotonic, sleep=clock.sleep,
                     open_i2c_bus=lambda number: opened.append(number) or bus) as sensor:
        reading = sensor.read()
    assert opened == [4]
    assert reading.pressure_pa == pytest.approx(99_000.0, abs=1.0)
    np.testing.assert_allclose(reading.quat_wxyz, [0.8, 0.6, 0.0, 0.0], atol=1e-3)
    assert imu_chip.calibration_bytes == profile.to_bytes()
    assert bus.closed and not sensor.is_open


def test_a_failure_while_opening_closes_what_was_opened():
    bus = FakeSMBus({0x76: BMP280Chip(), 0x28: BMP280Chip()})  # a barometer where the IMU should be
    clock = FakeClock()
    with pytest.raises(ChipIdError, match="BNO055"):
        with open_sensor(SensorConfig(backend="i2c"), clock=clock.monotonic, sleep=clock.sleep,
                         open_i2c_bus=lambda number: bus):
            pass
    assert bus.closed


def test_open_sensor_with_the_bno055_on_its_uart():
    pytest.importorskip("serial")
    bus = FakeSMBus({0x76: BMP280Chip(pressure_pa=101_000.0)})
    config = SensorConfig(backend="uart", port="bno055emu://")
    with open_sensor(config, open_i2c_bus=lambda number: bus) as sensor:
        reading = sensor.read()
        port = sensor.source.imu.transport.port
    assert reading.pressure_pa == pytest.approx(101_000.0, abs=1.0)
    np.testing.assert_allclose(reading.quat_wxyz, [1.0, 0.0, 0.0, 0.0], atol=1e-3)
    assert not port.is_open and bus.closed


def test_open_sensor_with_a_microcontroller_stream():
    pytest.importorskip("serial")
    config = SensorConfig(backend="mcu", port="mcuemu://", read_timeout_s=2.0)
    with open_sensor(config) as sensor:
        emulator = sensor.source.stream.port.emulator
        emulator.queue_sample(1000, pressure_pa=100_123.0)
        assert sensor.read().pressure_pa == pytest.approx(100_123.0)
    assert not emulator.is_open


def test_sim_backends_need_the_explorers_builder():
    with pytest.raises(NotImplementedError, match="build_scene"):
        with open_backends(config_from_dict({})):
            pass


def test_sim_backends_are_built_by_the_given_callable():
    log = []

    @contextlib.contextmanager
    def builder(config):
        log.append(("build", config.robot.spec))
        yield "robot", "sensor"
        log.append("closed")

    config = config_from_dict({"robot": {"spec": "armar6"}})
    with open_backends(config, sim_builder=builder) as (robot, sensor):
        assert (robot, sensor) == ("robot", "sensor")
    assert log == [("build", "armar6"), "closed"]


def test_simulation_and_hardware_do_not_mix():
    config = config_from_dict({"sensor": {"backend": "emulated"}})
    with pytest.raises(ValueError, match=r"robot\.backend = 'sim' and sensor\.backend = 'emulated'"):
        with open_backends(config):
            pass


def test_object_sections_resolve_paths_and_expand_a_single_size(tmp_path):
    path = tmp_path / "rig.json"
    path.write_text('{"object": {"name": "mug", "half_extent_m": 0.05, "reference_mesh": "mug.stl", '
                    '"centre_m": [0.3, -0.3, 0.9]}, "exploration": {"touches": 7, "use_normals": false}}')
    config = load_config(path)
    assert config.object.half_extent_m == (0.05, 0.05, 0.05)
    assert config.object.centre_m == (0.3, -0.3, 0.9)
    assert config.object.reference_mesh == tmp_path / "mug.stl"
    assert (config.exploration.touches, config.exploration.use_normals) == (7, False)


def test_obstacles_reach_the_rig_and_the_simulation_adds_its_table():
    from explorer.backends import _obstacles
    from robots.sim_world import TableSpec

    config = config_from_dict({"robot": {"backend": "emulated", "obstacles_m": [[0.4, -0.3, 0.37, 0.3, 0.4, 0.37]]},
                               "sensor": {"backend": "emulated"}})
    assert config.robot.obstacles_m == ((0.4, -0.3, 0.37, 0.3, 0.4, 0.37),)
    assert _obstacles(config) == (((0.4, -0.3, 0.37), (0.3, 0.4, 0.37)),)
    assert _obstacles(config_from_dict({})) == (TableSpec().box_m(),)
