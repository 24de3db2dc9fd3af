"""Simulation profiles: names, files, validation, what they build, and that a seed repeats a run."""
from __future__ import annotations

import math
import pickle
from dataclasses import fields, replace

import numpy as np
import pytest

from common.pad_state import PadState
from sensor.sim.bno055 import BNO055Config, BNO055Noise, SimulatedBNO055
from sensor.sim.pad_drift import PadDrift, PadDriftState
from explorer.sim_profile import (PARAMETER_SOURCES, PROFILES, SimProfile, format_parameter_table, get_profile,
                                load_profile_file, profile_from_dict)
from sensor.sim_sensor import SimulatedSensorConfig


def test_the_default_profile_is_the_model_every_earlier_figure_used():
    assert get_profile(None).name == "datasheet-noise"
    assert get_profile(None).sensor_config() == SimulatedSensorConfig()
    ideal = PROFILES["ideal"].sensor_config()
    assert ideal == SimulatedSensorConfig().noiseless()


def test_every_hardware_like_parameter_has_a_source():
    names = [f.name for f in fields(SimProfile) if f.name != "name"]
    assert set(PARAMETER_SOURCES) == set(names)
    assert all(PARAMETER_SOURCES[n] for n in names)
    table = format_parameter_table()
    assert all(n in table for n in names) and "hardware-like" in table


def test_unknown_names_and_bad_values_are_refused_naming_the_field(tmp_path):
    with pytest.raises(ValueError, match="unknown simulation profile 'hardware_like'.*did you mean 'hardware-like'"):
        get_profile("hardware_like")
    with pytest.raises(ValueError, match="joint_offset_std_deg must be >= 0"):
        replace(PROFILES["hardware-like"], joint_offset_std_deg=-1.0)
    with pytest.raises(ValueError, match="link_length_std_mm must be >= 0"):
        replace(PROFILES["hardware-like"], link_length_std_mm=-0.5)
    bad_links = tmp_path / "links.toml"
    bad_links.write_text("link_lenght_std_mm = 1.0\n")
    with pytest.raises(ValueError, match="links.toml: link_lenght_std_mm: unknown profile parameter.*link_length_std_mm"):
        load_profile_file(bad_links)
    with pytest.raises(ValueError, match="imu_latency_s must be finite"):
        replace(PROFILES["ideal"], imu_latency_s=math.inf)
    with pytest.raises(ValueError, match="joint_ofset_std_deg: unknown profile parameter.*joint_offset_std_deg"):
        profile_from_dict({"joint_ofset_std_deg": 1.0})
    with pytest.raises(ValueError, match="base: unknown profile"):
        profile_from_dict({"base": "perfect"})
    bad = tmp_path / "lab.toml"
    bad.write_text('spring_friction_nm = "strong"\n')
    with pytest.raises(ValueError, match="lab.toml.*spring_friction_nm must be a number"):
        load_profile_file(bad)


def test_a_toml_file_overrides_single_parameters_of_its_base(tmp_path):
    path = tmp_path / "my-lab.toml"
    path.write_text('base = "hardware-like"\njoint_offset_std_deg = 0.2\n')
    profile = get_profile(str(path))
    assert profile.name == "my-lab" and profile.joint_offset_std_deg == 0.2
    assert replace(profile, name="hardware-like", joint_offset_std_deg=PROFILES["hardware-like"].joint_offset_std_deg) \
        == PROFILES["hardware-like"]
    assert "joint_offset_std_deg" in profile.changed_parameters()


def test_joint_offsets_are_seeded_and_have_the_configured_spread():
    profile = PROFILES["hardware-like"]
    assert np.array_equal(profile.joint_offsets_rad(7, 3), profile.joint_offsets_rad(7, 3))
    assert not np.array_equal(profile.joint_offsets_rad(7, 3), profile.joint_offsets_rad(7, 4))
    draws = np.concatenate([profile.joint_offsets_rad(7, s) for s in range(300)])
    assert np.degrees(draws.std()) == pytest.approx(profile.joint_offset_std_deg, rel=0.1)
    assert not np.any(PROFILES["datasheet-noise"].joint_offsets_rad(7, 3))


def _state(t, quat=(1.0, 0.0, 0.0, 0.0)):
    return PadState(t_s=t, position_m=np.zeros(3), quat_wxyz=np.asarray(quat, float), lin_vel_mps=np.zeros(3),
                    ang_vel_radps=np.zeros(3), normal_force_n=0.0)


def test_imu_latency_reports_the_pose_of_that_long_ago():
    latency = 0.05
    imu = SimulatedBNO055(BNO055Config(noise=BNO055Noise.off(), quantise=False, latency_s=latency),
                          np.random.default_rng(0))
    dt, rate = 1 / 480, 1.0  # turning about z at 1 rad/s
    samples = []
    for k in range(480):
        t = k * dt
        sample = imu.step(_state(t, (math.cos(rate * t / 2), 0.0, 0.0, math.sin(rate * t / 2))))
        if sample is not None:
            samples.append(sample)
    late = [s for s in samples if s.t_s > 0.2]
    for s in late:
        angle = 2 * math.atan2(s.quat_wxyz[3], s.quat_wxyz[0])
        assert angle == pytest.approx(rate * (s.t_s - latency), abs=rate * dt + 1e-9)


def test_heading_offset_turns_about_the_vertical_only():
    noise = replace(BNO055Noise.off(), heading_offset_std_rad=math.radians(3.0))
    angles = []
    for seed in range(200):
        imu = SimulatedBNO055(BNO055Config(noise=noise, quantise=False), np.random.default_rng(seed))
        q = imu.step(_state(0.0)).quat_wxyz
        assert abs(q[1]) < 1e-12 and abs(q[2]) < 1e-12
        angles.append(2 * math.atan2(q[3], q[0]))
    assert np.degrees(np.std(angles)) == pytest.approx(3.0, rel=0.15)


def test_pad_creep_and_contact_temperature_follow_their_time_constants():
    drift = PadDriftState(PadDrift(creep_fraction=0.1, creep_time_constant_s=1.0, thermal_pa_per_k=100.0,
                                   contact_temperature_difference_k=-5.0, thermal_time_constant_s=100.0))
    extra = [drift.step(1000.0, True, 0.01) for _ in range(100)]  # 1 s held at 1000 Pa
    creep_1s = 0.1 * 1000.0 * (1 - math.exp(-1.0))
    thermal_1s = 100.0 * -5.0 * (1 - math.exp(-1.0 / 100.0))
    assert extra[-1] == pytest.approx(creep_1s + thermal_1s, rel=1e-6)
    for _ in range(1000):
        drift.step(0.0, False, 0.01)  # released: creep gone, temperature relaxing back
    assert abs(drift.creep_pa) < 0.01 and -5.0 < drift.temperature_change_k < 0.0


def test_cli_refuses_a_bad_profile_with_exit_2(tmp_path, capsys):
    from scripts import explore, sensor_eval

    with pytest.raises(SystemExit) as exit_info:
        sensor_eval.main(["--profile", "hardware"])
    assert exit_info.value.code == 2
    assert "unknown simulation profile 'hardware'" in capsys.readouterr().err
    path = tmp_path / "p.toml"
    path.write_text("imu_latency_s = -1\n")
    with pytest.raises(SystemExit) as exit_info:
        explore.main(["--profile", str(path), "--out", str(tmp_path / "run")])
    assert exit_info.value.code == 2
    assert "imu_latency_s must be >= 0" in capsys.readouterr().err


@pytest.mark.parametrize("profile, noted", [("hardware-like", True), ("datasheet-noise", False), ("ideal", False)])
def test_explore_notes_an_uncalibrated_arm_once_before_it_runs(tmp_path, capsys, profile, noted):
    """A profile that draws joint-offset or link-length errors, run without ``--calibration``: one
    line that says so and gives the calibration command (stopped here by an unusable --out)."""
    from scripts import explore

    out = tmp_path / "run"
    out.mkdir()
    (out / "something").write_text("x")                        # not empty: refused after the note
    with pytest.raises(SystemExit) as exit_info:
        explore.main(["--profile", profile, "--seed", "3", "--out", str(out)])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    notes = [line for line in err.splitlines() if "note: profile" in line]
    assert len(notes) == (1 if noted else 0)
    if noted:
        expected = get_profile(profile)
        assert f"joint offsets {expected.joint_offset_std_deg:g} deg" in notes[0]
        assert "python -m scripts.calibrate_joints --profile hardware-like --robot armar3 --seed 3" in notes[0]

def test_rig_config_names_the_profile(tmp_path):
    from explorer.config import config_from_dict

    config = config_from_dict({"robot": {"backend": "sim"}, "sensor": {"backend": "sim"},
                               "simulation": {"profile": "hardware-like"}})
    assert config.simulation.profile == "hardware-like"
    with pytest.raises(ValueError, match="simulation.profile: unknown profile 'hw'"):
        config_from_dict({"simulation": {"profile": "hw"}})
    (tmp_path / "lab.toml").write_text("no_such = 1\n")
    with pytest.raises(ValueError, match="simulation.profile: .*no_such: unknown profile parameter"):
        config_from_dict({"simulation": {"profile": "lab.toml"}}, base_dir=tmp_path)


def test_same_seed_same_bytes_of_the_sensor_stream_for_a_short_press():
    from explorer.sensor_evaluation.press_rig import build_rig
    from explorer.sensor_evaluation.scene import random_touch_site
    from explorer.sensor_evaluation.trials import PressSpec, run_press
    import objects

    profile = PROFILES["hardware-like"]
    rig = replace(build_rig("armar3"), spring_friction_nm=profile.spring_friction_nm)
    rig = replace(rig, spec=profile.robot_spec(rig.spec))
    flat = objects.load("flat")

    def stream(seed):
        rng = np.random.default_rng(seed)
        spec = PressSpec("flat", random_touch_site(flat, rng), math.radians(20), 1.0, 0.5, 1.0, seed)
        recording = run_press(rig, flat, spec, {"live": profile.sensor_config()})
        return pickle.dumps([(r.t_s, r.pressure_pa, tuple(r.quat_wxyz)) for r in recording.streams["live"]])

    first = stream(5)
    assert first == stream(5)
    assert first != stream(6)
