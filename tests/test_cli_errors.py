"""Every command refuses bad input with one line naming the option (or file) and the fix, exit
status 2, no traceback and nothing written. docs/ERRORS.md lists these cases; most fail before any
simulation starts."""
from __future__ import annotations

import json
import shutil

import pytest

from explorer.run import RunSettings, explore


def run_main(main, args, capsys):
    """Run a command's ``main``; returns ``(exit status, stderr)``."""
    try:
        status = main(args)
    except SystemExit as exit_:
        status = exit_.code
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return status, err


def last_line(err: str) -> str:
    return err.strip().splitlines()[-1]


@pytest.fixture(scope="module")
def recorded_run(tmp_path_factory):
    """A finished 2-touch sphere run (session, contacts.csv, metrics.json, reconstruction.ply)."""
    out = tmp_path_factory.mktemp("recorded") / "run"
    explore(RunSettings(object="sphere", touches=2, eval_every=0, mesh_resolution=24, reach_samples=0), out)
    return out


def snapshot(directory):
    return {p.relative_to(directory): p.read_bytes() for p in sorted(directory.rglob("*")) if p.is_file()}


# ---- tactile-explore -------------------------------------------------------------------------

@pytest.mark.parametrize("args, message", [
    (["--seed", "-1"], "argument --seed: must be at least 0, got -1"),
    (["--seed", "x"], "argument --seed: expected an integer"),
    (["--touches", "0"], "argument --touches: must be at least 1"),
    (["--object", "nosuch"], "--object: unknown object 'nosuch'; choose one of"),
    (["--object", "missing.stl"], "--object missing.stl: mesh file not found"),
    (["--robot", "r2d2"], "--robot: unknown robot 'r2d2'; choose one of"),
    (["--strategy", "greedy"], "argument --strategy: invalid choice"),
    (["--probe-depth", "-5"], "argument --probe-depth: must be a finite number >= 0, got -5"),
    (["--reach-samples", "-1"], "argument --reach-samples: must be at least 0, got -1"),
])
def test_explore_refuses_bad_arguments_before_anything_is_written(tmp_path, capsys, args, message):
    from scripts.explore import main

    status, err = run_main(main, args + ["--out", str(tmp_path / "run")], capsys)
    assert status == 2 and message in last_line(err)
    assert "device" not in last_line(err) and "--resume" not in last_line(err)
    assert not (tmp_path / "run").exists()


def test_explore_refuses_an_object_too_large_for_the_rig_before_anything_is_written(tmp_path, capsys, monkeypatch):
    """A 50 cm crate turned by the stand would reach into the arm waiting at rest (it stopped after its
    first contact with the wrist pressed on it); the hand-held range of the units check allows it."""
    import trimesh

    from scripts.explore import main

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    trimesh.creation.box(extents=(0.5, 0.3, 0.2)).export(tmp_path / "crate.stl")
    status, err = run_main(main, ["--object", str(tmp_path / "crate.stl"), "--touches", "3",
                                  "--out", str(tmp_path / "run")], capsys)
    assert status == 2
    assert "too large for this rig" in last_line(err) and "into the arm waiting at rest" in last_line(err)
    assert not (tmp_path / "run").exists()


def test_a_run_records_the_shift_of_a_user_mesh_it_centred(tmp_path, capsys, monkeypatch):
    """metrics.json and the session name the shift, so the reconstruction can be put back in the file's frame."""
    import warnings

    import numpy as np
    import trimesh

    from scripts.explore import main

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    part = trimesh.creation.box(extents=(0.08, 0.06, 0.04))
    part.apply_translation([0.04, 0.03, 0.02])  # drawn from its corner
    part.export(tmp_path / "part.stl")
    with pytest.warns(UserWarning, match="moved the origin there"):
        status, _ = run_main(main, ["--object", str(tmp_path / "part.stl"), "--touches", "1",
                                    "--out", str(tmp_path / "run")], capsys)
    assert status == 0
    metrics = json.loads((tmp_path / "run" / "metrics.json").read_text())
    metadata = json.loads((tmp_path / "run" / "session" / "metadata.json").read_text())
    np.testing.assert_allclose(metrics["object_file_shift_mm"], [40.0, 30.0, 20.0], atol=1e-6)
    assert metadata["object_file_shift_mm"] == metrics["object_file_shift_mm"]

    from explorer.replay import SessionReplay

    session = tmp_path / "run" / "session"
    with pytest.warns(UserWarning, match="moved the origin there"):  # the replay loads the file as the run did
        replayed = SessionReplay(session)
    np.testing.assert_allclose(replayed.truth.bounds, [[-0.04, -0.03, -0.02], [0.04, 0.03, 0.02]],
                               atol=1e-9)
    del metadata["object_file_shift_mm"]  # as a session recorded before meshes were centred: the file's frame
    (session / "metadata.json").write_text(json.dumps(metadata))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # kept in its frame: nothing moved, nothing to warn about
        replayed = SessionReplay(session)
    np.testing.assert_allclose(replayed.truth.bounds, [[0.0, 0.0, 0.0], [0.08, 0.06, 0.04]], atol=1e-9)


def test_explore_refuses_an_out_that_is_a_file_or_under_one(tmp_path, capsys):
    from scripts.explore import main

    (tmp_path / "f").write_text("x")
    status, err = run_main(main, ["--out", str(tmp_path / "f")], capsys)
    assert status == 2 and "--out" in err and "is a file" in err
    status, err = run_main(main, ["--out", str(tmp_path / "f" / "run")], capsys)
    assert status == 2 and "cannot be created" in err


def test_explore_refuses_an_out_under_a_read_only_directory(tmp_path, capsys, monkeypatch):
    import os

    from scripts import _cli
    from scripts.explore import main

    read_only = tmp_path / "shared"
    read_only.mkdir()
    # root ignores permission bits, so the directory is made read-only for the check itself
    monkeypatch.setattr(_cli.os, "access", lambda path, mode: os.path.realpath(path) != str(read_only.resolve()))
    status, err = run_main(main, ["--out", str(read_only / "run")], capsys)
    assert status == 2 and f"{read_only} is not writable; choose another directory" in last_line(err)
    assert list(read_only.iterdir()) == []


def test_explore_refuses_a_finished_run_without_resume_and_resume_without_a_run(recorded_run, tmp_path, capsys):
    from scripts.explore import main

    before = snapshot(recorded_run)
    status, err = run_main(main, ["--object", "sphere", "--out", str(recorded_run)], capsys)
    assert status == 2 and "already holds the outputs of an earlier run" in err and "--resume" in err
    assert snapshot(recorded_run) == before
    status, err = run_main(main, ["--object", "sphere", "--out", str(tmp_path / "none"), "--resume"], capsys)
    assert status == 2 and "holds no run to continue with --resume" in err


def test_explore_resume_with_other_settings_is_a_usage_error_without_device_talk(recorded_run, tmp_path, capsys):
    from scripts.explore import main

    out = tmp_path / "run"
    shutil.copytree(recorded_run, out)
    before = snapshot(out)
    status, err = run_main(main, ["--object", "sphere", "--strategy", "random", "--out", str(out), "--resume"],
                           capsys)
    assert status == 2 and "strategy: recorded 'variance', now 'random'" in last_line(err)
    assert "device" not in last_line(err)
    assert snapshot(out) == before


def test_explore_gui_without_a_display_fails_at_once(tmp_path, capsys, monkeypatch):
    from scripts.explore import main

    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    status, err = run_main(main, ["--gui", "--out", str(tmp_path / "run")], capsys)
    assert status == 2 and "--gui: no display" in err and "run without --gui" in err
    monkeypatch.setenv("DISPLAY", ":97")  # no such X server
    status, err = run_main(main, ["--gui", "--out", str(tmp_path / "run")], capsys)
    assert status == 2 and "no X server" in err


def test_explore_config_errors_name_the_field(tmp_path, capsys):
    from scripts.explore import main

    config = tmp_path / "rig.toml"
    config.write_text('[robot]\nbackend = "sim"\n[sensor]\nbackend = "sim"\n[exploration]\ntouches = "many"\n')
    status, err = run_main(main, ["--config", str(config), "--out", str(tmp_path / "run")], capsys)
    assert status == 2 and "exploration.touches" in last_line(err)
    config.write_text('[robot]\nbackend = "sim"\nspeed = 3\n')
    status, err = run_main(main, ["--config", str(config), "--out", str(tmp_path / "run")], capsys)
    assert status == 2 and "robot.speed: unknown key" in last_line(err)
    assert not (tmp_path / "run").exists()


# ---- tactile-reconstruct ---------------------------------------------------------------------

def test_reconstruct_never_overwrites_a_run(recorded_run, capsys):
    from scripts.reconstruct import main

    before = snapshot(recorded_run)
    status, err = run_main(main, [str(recorded_run), "--out", str(recorded_run), "--start-threshold-pa", "300"],
                           capsys)
    assert status == 2 and "already holds the outputs of an earlier run" in err
    assert snapshot(recorded_run) == before


@pytest.mark.parametrize("missing", ["events.jsonl", "readings.csv", "joint_states.csv", "metadata.json"])
def test_reconstruct_names_the_missing_file_of_an_incomplete_session(recorded_run, tmp_path, capsys, missing):
    from scripts.reconstruct import main

    copy = tmp_path / "run"
    shutil.copytree(recorded_run, copy)
    (copy / "session" / missing).unlink()
    status, err = run_main(main, [str(copy / "session"), "--out", str(tmp_path / "replay")], capsys)
    assert status == 2 and missing in last_line(err)
    assert not (tmp_path / "replay").exists()


def test_reconstruct_refuses_a_folder_that_is_no_session(tmp_path, capsys):
    from scripts.reconstruct import main

    (tmp_path / "photos").mkdir()
    status, err = run_main(main, [str(tmp_path / "photos"), "--out", str(tmp_path / "replay")], capsys)
    assert status == 2 and "is not a session: metadata.json is missing" in err
    status, err = run_main(main, [str(tmp_path / "none"), "--out", str(tmp_path / "replay")], capsys)
    assert status == 2 and "does not exist" in err


def test_reconstruct_skips_a_nan_pressure_naming_file_and_line(recorded_run, tmp_path, capsys):
    from scripts.reconstruct import main

    copy = tmp_path / "run"
    shutil.copytree(recorded_run, copy)
    path = copy / "session" / "readings.csv"
    lines = path.read_text().splitlines()
    values = lines[5].split(",")
    values[1] = "nan"
    lines[5] = ",".join(values)  # line 6 of the file
    path.write_text("\n".join(lines) + "\n")
    status, err = run_main(main, [str(copy), "--out", str(tmp_path / "replay"), "--resolution", "16"], capsys)
    assert status is None or status == 0
    notes = json.loads((tmp_path / "replay" / "metrics.json").read_text())["notes"]
    assert any("readings.csv" in note and "line 6" in note for note in notes), notes


def test_reconstruct_refuses_out_of_range_settings(recorded_run, tmp_path, capsys):
    from scripts.reconstruct import main

    for args, message in ((["--start-threshold-pa", "-5"], "argument --start-threshold-pa"),
                          (["--noise", "nan"], "argument --noise"),
                          (["--resolution", "2"], "argument --resolution: must be at least 8")):
        status, err = run_main(main, [str(recorded_run), "--out", str(tmp_path / "replay")] + args, capsys)
        assert status == 2 and message in last_line(err)
    assert not (tmp_path / "replay").exists()


# ---- tactile-report --------------------------------------------------------------------------

def test_report_says_which_figures_it_could_not_draw(recorded_run, tmp_path, capsys):
    from scripts.report import main

    copy = tmp_path / "run"
    shutil.copytree(recorded_run, copy)
    (copy / "metrics.json").unlink()  # as after a killed run
    (copy / "reconstruction.ply").unlink()
    main([str(copy), "--out", str(tmp_path / "report")])
    out = capsys.readouterr().out
    assert "not drawn: metrics.json is missing" in out
    assert "not drawn: reconstruction_error.png" in out and "not drawn: error_vs_touches.png" in out


@pytest.mark.parametrize("name, content", [("metrics.json", "{not json"), ("contacts.csv", "touch,x\n1,oops\n")])
def test_report_on_a_corrupt_file_gives_one_line(recorded_run, tmp_path, capsys, name, content):
    from scripts.report import main

    copy = tmp_path / "run"
    shutil.copytree(recorded_run, copy)
    (copy / name).write_text(content)
    status, err = run_main(main, [str(copy), "--out", str(tmp_path / "report")], capsys)
    assert status == 2 and name in last_line(err)


# ---- tactile-teleop --------------------------------------------------------------------------

def test_teleop_refuses_an_existing_out_and_a_script_that_is_not_json(recorded_run, tmp_path, capsys):
    from scripts.teleop import main

    script = tmp_path / "touches.json"
    script.write_text("[{\"duration_s\": 1.0}]")
    status, err = run_main(main, ["--object", "sphere", "--headless", "--script", str(script),
                                  "--out", str(recorded_run)], capsys)
    assert status == 2 and "already holds the outputs of an earlier run" in last_line(err)
    script.write_text("duration 1 s, then press")
    status, err = run_main(main, ["--object", "sphere", "--headless", "--script", str(script),
                                  "--out", str(tmp_path / "teleop")], capsys)
    assert status == 2 and f"script file {script} is not JSON" in last_line(err)
    assert not (tmp_path / "teleop").exists()


def test_teleop_with_a_window_but_no_display_fails_at_once(tmp_path, capsys, monkeypatch):
    from scripts.teleop import main

    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    status, err = run_main(main, ["--object", "sphere", "--out", str(tmp_path / "t")], capsys)
    assert status == 2 and "no display" in err and "--headless" in err
    pytest.importorskip("rerun")
    status, err = run_main(main, ["--object", "sphere", "--out", str(tmp_path / "t"),
                                  "--rerun", str(tmp_path / "teleop.rrd")], capsys)
    assert status == 2 and "no display" in err
    assert list(tmp_path.iterdir()) == []  # no empty recording left behind


# ---- tactile-sweep, tactile-gpis-bench, sensor-monitor ---------------------------------------

def test_sweep_refuses_a_negative_probe_depth(tmp_path, capsys):
    from scripts.sweep import main

    status, err = run_main(main, ["--objects", "sphere", "--probe-depth", "-1", "--out", str(tmp_path / "s")], capsys)
    assert status == 2 and "argument --probe-depth: must be a finite number >= 0" in last_line(err)
    assert not (tmp_path / "s").exists()


def test_sweep_to_an_unreachable_ray_cluster_fails_at_once(tmp_path, capsys):
    from scripts.sweep import main

    status, err = run_main(main, ["--ray", "127.0.0.1:1", "--out", str(tmp_path / "sweep")], capsys)
    assert status == 2 and "--ray 127.0.0.1:1: no Ray cluster answers there" in err
    status, err = run_main(main, ["--touches", "0", "--out", str(tmp_path / "sweep")], capsys)
    assert status == 2 and "--touches must be at least 1" in err
    assert not (tmp_path / "sweep").exists()


@pytest.mark.parametrize("args, message", [
    (["--seeds", "0"], "argument --seeds: must be at least 1"),
    (["--contacts", "0"], "argument --contacts: must be at least 1"),
    (["--objects", "teapot"], "--objects: unknown object 'teapot'"),
    (["--normal-std-mm", "-1"], "argument --normal-std-mm"),
    (["--methods", "normals;magic"], "--methods: unknown method 'magic'"),
])
def test_gpis_bench_refuses_bad_arguments_and_writes_nothing(tmp_path, capsys, args, message):
    from scripts.gpis_benchmark import main

    status, err = run_main(main, args + ["--out", str(tmp_path / "bench")], capsys)
    assert status == 2 and message in last_line(err)
    assert not (tmp_path / "bench").exists()


def test_sensor_monitor_never_overwrites_a_recording(recorded_run, tmp_path, capsys):
    from scripts.sensor_monitor import main

    status, err = run_main(main, ["--emulate", "--record", str(recorded_run)], capsys)
    assert status == 2 and "--record" in err and "resume=True" not in err
    (tmp_path / "m.csv").write_text("t\n")
    status, err = run_main(main, ["--emulate", "--csv", str(tmp_path / "m.csv")], capsys)
    assert status == 2 and "--csv" in err and (tmp_path / "m.csv").read_text() == "t\n"


def test_the_progress_bar_of_a_resumed_run_starts_at_the_recorded_touches(recorded_run, capsys):
    from types import SimpleNamespace

    from scripts.explore import _with_progress

    settings = SimpleNamespace(touches=5, object="sphere", strategy="variance")
    seen = []

    def run(progress, status):
        for _ in range(3):
            progress(SimpleNamespace(kind="contact"))
        seen.append(True)
        return "done"

    assert _with_progress(settings, run, recorded_run, resume=True) == ("done", 0)
    err = capsys.readouterr().err
    assert seen and "2/5" in err and "5/5" in err and "0/5" not in err


def test_explore_refuses_a_calibration_of_another_arm_or_none_at_all(tmp_path, capsys):
    import json

    from scripts.explore import main

    calibration = tmp_path / "joint_calibration.json"
    calibration.write_text(json.dumps(dict(robot="armar6", profile="hardware-like", seed=0,
                                           fitted_offset_deg=[0.0] * 8)))
    status, err = run_main(main, ["--object", "sphere", "--robot", "armar3", "--profile", "hardware-like",
                                  "--calibration", str(calibration), "--out", str(tmp_path / "run")], capsys)
    assert status == 2 and "is of robot 'armar6'" in last_line(err) and "--robot" in last_line(err)
    status, err = run_main(main, ["--object", "sphere", "--calibration", str(tmp_path / "none.json"),
                                  "--out", str(tmp_path / "run")], capsys)
    assert status == 2 and "--calibration: calibration file not found" in last_line(err)
    assert not (tmp_path / "run").exists()



def test_the_run_reading_scripts_load_the_object_in_the_frame_the_run_explored_it_in(tmp_path, monkeypatch):
    import json
    import warnings

    import numpy as np
    import trimesh

    from scripts._cli import recorded_object

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    part = trimesh.creation.box(extents=(0.08, 0.06, 0.04))
    part.apply_translation([0.04, 0.03, 0.02])
    part.export(tmp_path / "part.stl")
    name = str(tmp_path / "part.stl")
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "metrics.json").write_text(json.dumps({"object": name}))  # recorded before centring
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        before = recorded_object("prog", tmp_path / "run", name)
    np.testing.assert_allclose(before.mesh.bounds, [[0.0, 0.0, 0.0], [0.08, 0.06, 0.04]], atol=1e-9)
    (tmp_path / "run" / "metrics.json").write_text(json.dumps({"object": name, "object_file_shift_mm": [40, 30, 20]}))
    with pytest.warns(UserWarning, match="moved the origin there"):
        centred = recorded_object("prog", tmp_path / "run", name)
    np.testing.assert_allclose(centred.mesh.bounds, [[-0.04, -0.03, -0.02], [0.04, 0.03, 0.02]], atol=1e-9)


def test_a_run_whose_mesh_file_does_not_load_is_one_usage_line(tmp_path, capsys):
    """A run recorded with a mesh file named relative to another directory: the run-reading scripts
    stop with one line naming the run, the object and the fix, not a traceback."""
    from scripts import reach_report
    from scripts._cli import recorded_object

    assert recorded_object("x", tmp_path, "sphere").name == "sphere"
    run = tmp_path / "run"
    run.mkdir()
    (run / "metrics.json").write_text(json.dumps({"object": "parts/cup.stl", "robot": "armar3", "seed": 0}))
    with pytest.raises(SystemExit) as exit_info:
        reach_report.main([str(run), "--recompute"])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith(f"reach_report: error: {run}: its object 'parts/cup.stl' does not load")
    assert "run this from the directory the run was made in" in err[0]
