"""``tactile-explore --config``: a configured rig (emulated hardware, or the simulation with the object
left in place) runs the same loop, writes the same outputs and resumes after a stop."""
from __future__ import annotations

import json

import numpy as np
import pytest

from explorer.config import config_from_dict
from explorer.recording import read_contacts_csv
from explorer.backends import open_rig, run_settings
from explorer.run import run_on_rig
from explorer.session import read_session
from scripts.explore import main as explore_main

RADIUS_M = 0.04
OFFSET_M = (0.004, -0.003, 0.002)


def _dry_run_config(tmp_path, touches, reach_samples=8):
    path = tmp_path / "dry_run.toml"
    path.write_text(f"""
[robot]
backend = "emulated"
[sensor]
backend = "emulated"
[object]
name = "virtual sphere"
[emulation]
sphere_radius_m = {RADIUS_M}
sphere_offset_m = {list(OFFSET_M)}
[exploration]
touches = {touches}
eval_every = 0
mesh_resolution = 24
reach_samples = {reach_samples}
""")
    return path


def test_the_command_explores_an_emulated_rig_and_resumes_it(tmp_path, one_torch_thread, capsys):
    config = _dry_run_config(tmp_path, touches=3)
    out = tmp_path / "run"
    assert explore_main(["--config", str(config), "--out", str(out)]) == 0
    first = json.loads((out / "metrics.json").read_text())
    assert first["touches"] == 3 and first["backend"] == "robot emulated, sensor emulated"
    points, normals = read_contacts_csv(out / "contacts.csv")
    assert len(points) == first["contacts"] >= 2
    centre = np.asarray(OFFSET_M)  # object frame: origin at object.centre_m, the sphere off by the offset
    radial = (points - centre) / np.linalg.norm(points - centre, axis=1, keepdims=True)
    assert np.all(np.abs(np.linalg.norm(points - centre, axis=1) - RADIUS_M) < 1.5e-3)
    assert np.all(np.degrees(np.arccos(np.clip(np.sum(normals * radial, axis=1), -1, 1))) < 5.0)
    assert "position_rmse_mm" in first  # the emulated sphere is the reference surface
    assert first["reach_breakdown"]["samples"] == 8  # the configuration's, not the default 64

    assert explore_main(["--config", str(config), "--out", str(out), "--resume", "--touches", "5",
                         "--reach-samples", "4"]) == 0
    resumed = json.loads((out / "metrics.json").read_text())
    assert resumed["touches"] == 5 and resumed["completed"]
    assert resumed["reach_breakdown"]["samples"] == 4  # the flag over the file; an evaluation setting may change
    after, _ = read_contacts_csv(out / "contacts.csv")
    np.testing.assert_array_equal(after[:len(points)], points)
    session = read_session(out / "session")
    assert session.closed_cleanly and len(session.metadata["resumed"]) == 1
    assert '"touches": 5' in capsys.readouterr().out


def test_flags_that_belong_in_the_configuration_are_refused(tmp_path, capsys):
    config = _dry_run_config(tmp_path, touches=3)
    with pytest.raises(SystemExit) as exit_:
        explore_main(["--config", str(config), "--object", "box"])
    assert exit_.value.code == 2
    assert "--object does not go with --config" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        explore_main(["--config", str(tmp_path / "missing.toml")])
    assert "configuration file not found" in capsys.readouterr().err


def test_hardware_without_the_objects_size_is_refused_before_opening_a_device():
    config = config_from_dict({"robot": {"backend": "serial", "port": "/dev/does-not-exist"},
                               "sensor": {"backend": "i2c"}, "object": {"centre_m": [0.4, -0.3, 0.9]}})
    with pytest.raises(ValueError, match=r"object\.half_extent_m: required on hardware"):
        with open_rig(config):
            pass


def test_a_simulated_rig_from_a_configuration_keeps_the_object_in_place(tmp_path, one_torch_thread):
    config = config_from_dict({"robot": {"backend": "sim"}, "sensor": {"backend": "sim"},
                               "object": {"name": "sphere", "centre_m": [0.36, -0.32, 0.92]},
                               "exploration": {"touches": 3, "eval_every": 0, "mesh_resolution": 24,
                                               "reach_samples": 0}})
    with open_rig(config) as rig:
        assert rig.positioner.poses == (rig.positioner.pose(),)
        np.testing.assert_allclose(rig.positioner.centre_m, [0.36, -0.32, 0.92])
        result = run_on_rig(rig, run_settings(config), tmp_path)
    contacts = [r for r in result.records if r.kind == "contact"]
    assert len(contacts) >= 2
    radius = float(np.max(rig.reference.vertices, axis=0)[0])
    for record in contacts:
        assert abs(np.linalg.norm(record.position_m) - radius) < 1.5e-3
    assert result.metrics["backend"] == "robot sim, sensor sim"
    assert "reach_breakdown" not in result.metrics and "coverage_ceiling" in result.metrics  # skipped: 0 samples
    # as many contacts placed on the truth cover at least what the run's did, and no more than the ceiling
    m = result.metrics
    assert m["coverage"] - 0.05 <= m["coverage_placed"] <= 1.05 * m["coverage_ceiling"]
