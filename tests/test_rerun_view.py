"""Rerun logging of a run and of a recorded session, read back with Rerun's own dataframe API."""
from __future__ import annotations

import sys

import numpy as np
import pytest

from explorer.rerun_view import TIMELINE, INSTALL_HINT


@pytest.mark.parametrize("command, argv", [
    ("scripts.explore", ["--object", "sphere", "--touches", "1", "--rerun", "x.rrd"]),
    ("scripts.teleop", ["--object", "sphere", "--rerun"]),
    ("scripts.reconstruct", [".", "--rerun", "x.rrd"]),
])
def test_without_rerun_one_line_names_the_extra_and_exits_2(command, argv, monkeypatch, capsys, tmp_path):
    import importlib

    monkeypatch.chdir(tmp_path)
    monkeypatch.setitem(sys.modules, "rerun", None)  # import rerun -> ImportError
    with pytest.raises(SystemExit) as stop:
        importlib.import_module(command).main(argv)
    assert stop.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and INSTALL_HINT in err[0]
    assert not (tmp_path / "x.rrd").exists()


def test_a_file_that_is_not_rrd_is_refused(capsys, tmp_path):
    pytest.importorskip("rerun", reason="rerun-sdk (viz extra) not installed")
    from scripts.reconstruct import main

    with pytest.raises(SystemExit) as stop:
        main([str(tmp_path), "--rerun", str(tmp_path / "x.txt")])
    assert stop.value.code == 2 and ".rrd" in capsys.readouterr().err


# ------------------------------------------------------------------ recordings read back
@pytest.fixture(scope="module")
def rr():
    pytest.importorskip("datafusion", reason="the dataframe reader needs rerun-sdk[catalog] (viz extra)")
    return pytest.importorskip("rerun", reason="rerun-sdk (viz extra) not installed")


@pytest.fixture(scope="module")
def logged_run(rr, tmp_path_factory):
    from explorer.rerun_view import RerunObserver, open_stream
    from explorer.run import RunSettings, explore

    out = tmp_path_factory.mktemp("rerun")
    observer = RerunObserver(open_stream(out / "run.rrd"), surface_every=1)
    result = explore(RunSettings(object="sphere", touches=4, seed=0, eval_every=0, mesh_resolution=32, reach_samples=0),
                     out / "run", observer=observer)
    return out, result


@pytest.fixture(scope="module")
def session(logged_run):
    from explorer.session import read_session

    return read_session(logged_run[0] / "run" / "session")


def read(rr, path, entity: str):
    """Rows of ``entity`` on the session timeline (one per logged time), via Rerun's dataframe API."""
    with rr.server.Server(datasets={"run": [str(path)]}) as server:
        dataset = server.client().get_dataset("run")
        frame = dataset.filter_contents([entity]).reader(index=TIMELINE).to_pandas()
    columns = [c for c in frame.columns if c.startswith(entity + ":")]
    return frame[frame[columns].notna().any(axis=1)], columns


def entity_paths(rr, path) -> set[str]:
    with rr.server.Server(datasets={"run": [str(path)]}) as server:
        schema = server.client().get_dataset("run").schema()
    return {str(c).split("Entity path: ")[1].split()[0] for c in schema if "Entity path: /" in str(c)}


SCENE = {"/world/object", "/world/object/truth", "/world/object/gpis", "/world/object/targets",
         "/world/object/approaches", "/world/object/suggestion", "/world/pad/path", "/touches",
         "/world/object/reconstruction", "/sensor/pressure_pa", "/sensor/compensated_pa",
         "/sensor/in_contact", "/sensor/orientation/w", "/sensor/orientation/z"}


def test_the_live_recording_holds_the_scene_and_every_sensor_reading(rr, logged_run, session):
    out, result = logged_run
    path = out / "run.rrd"
    paths = entity_paths(rr, path)
    assert SCENE <= paths, SCENE - paths
    touches = len(result.records)
    assert len(read(rr, path, "/touches")[0]) == touches
    targets, _ = read(rr, path, "/world/object/targets")
    assert len(targets) == touches and len(targets.iloc[-1]["/world/object/targets:Points3D:positions"]) == touches
    contacts = [r for r in result.records if r.kind == "contact"]
    if contacts:
        rows, _ = read(rr, path, "/world/object/contacts")
        final = np.stack(rows.iloc[-1]["/world/object/contacts:Points3D:positions"])
        assert len(final) == len(contacts)
        np.testing.assert_allclose(final[-1], contacts[-1].position_m, atol=1e-6)  # float32 in Rerun
    # Sensor streams: one row per recorded reading, values as recorded, on the session clock.
    pressure, (column,) = read(rr, path, "/sensor/pressure_pa")
    assert len(pressure) == len(session.readings)
    np.testing.assert_allclose(np.concatenate(pressure[column].to_numpy())[:5], session.readings.pressure_pa[:5])
    times = pressure[TIMELINE].to_numpy().astype("timedelta64[ns]").astype(np.int64) * 1e-9
    np.testing.assert_allclose(times[:5], session.readings.t_s[:5], atol=1e-8)
    w, (column,) = read(rr, path, "/sensor/orientation/w")
    np.testing.assert_allclose(np.concatenate(w[column].to_numpy())[-3:], session.readings.quat_wxyz[-3:, 0])
    state, (column,) = read(rr, path, "/sensor/in_contact")
    values = np.concatenate(state[column].to_numpy())
    assert set(np.unique(values)) <= {0.0, 1.0} and (values.max() == 1.0) == bool(contacts)
    compensated, (column,) = read(rr, path, "/sensor/compensated_pa")
    assert np.concatenate(compensated[column].to_numpy())[0] == 0.0  # the first reading is the baseline
    # The GPIS surface after each touch once it has two contacts, coloured per vertex.
    gpis, _ = read(rr, path, "/world/object/gpis")
    assert len(gpis) >= 1
    last = gpis.iloc[-1]
    assert len(last["/world/object/gpis:Mesh3D:vertex_colors"]) == len(last["/world/object/gpis:Mesh3D:vertex_positions"])


def test_the_session_replayed_into_rerun_matches_the_live_recording(rr, logged_run, session, tmp_path):
    from explorer.rerun_view import RerunObserver, log_session, open_stream

    out, result = logged_run
    replayed = tmp_path / "replay.rrd"
    touches = log_session(out / "run", RerunObserver(open_stream(replayed), surface_every=1))
    assert touches == len(result.records)
    assert SCENE - {"/world/object/suggestion"} <= entity_paths(rr, replayed)
    for entity in ("/sensor/pressure_pa", "/sensor/compensated_pa", "/touches", "/world/object/targets"):
        live, (column, *_) = read(rr, out / "run.rrd", entity)
        again, _ = read(rr, replayed, entity)
        assert len(again) == len(live), entity
    live, (column,) = read(rr, out / "run.rrd", "/sensor/compensated_pa")
    again, _ = read(rr, replayed, "/sensor/compensated_pa")
    np.testing.assert_allclose(np.concatenate(again[column].to_numpy()), np.concatenate(live[column].to_numpy()))
    # The replay updates the GPIS as the loop did (contacts and misses' free space): the same surface.
    live, _ = read(rr, out / "run.rrd", "/world/object/gpis")
    again, _ = read(rr, replayed, "/world/object/gpis")
    vertices = "/world/object/gpis:Mesh3D:vertex_positions"
    np.testing.assert_allclose(np.asarray(again.iloc[-1][vertices].tolist(), float),
                               np.asarray(live.iloc[-1][vertices].tolist(), float), atol=1e-7)


def test_a_replayed_miss_adds_its_free_space_to_the_gpis(rr, logged_run, tmp_path):
    import json
    import shutil

    from explorer.rerun_view import RerunObserver, log_session, open_stream

    out, result = logged_run
    session = tmp_path / "with_miss"
    shutil.copytree(out / "run" / "session", session)
    last_t = json.loads((session / "events.jsonl").read_text().splitlines()[-1])["t_s"]
    miss = dict(t_s=last_t + 1.0, kind="miss", index=len(result.records), result="miss", strategy="uniform",
                target_m=[0.06, 0.0, 0.0], approach_dir=[-1.0, 0.0, 0.0],
                free_space_m=[[0.07, 0.0, 0.0], [0.065, 0.0, 0.0], [0.06, 0.0, 0.0]])
    with open(session / "events.jsonl", "a", encoding="utf-8") as stream:
        stream.write(json.dumps(miss) + "\n")
    replayed = tmp_path / "miss.rrd"
    assert log_session(session, RerunObserver(open_stream(replayed), surface_every=1)) == len(result.records) + 1
    live, _ = read(rr, out / "run.rrd", "/world/object/gpis")
    again, _ = read(rr, replayed, "/world/object/gpis")
    vertices = "/world/object/gpis:Mesh3D:vertex_positions"
    before = np.asarray(live.iloc[-1][vertices].tolist(), float)
    after = np.asarray(again.iloc[-1][vertices].tolist(), float)
    assert before.shape != after.shape or not np.allclose(before, after, atol=1e-6)  # the free space moved it
