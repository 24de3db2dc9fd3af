"""What a run leaves on disk stays true: a resumed run carries the earlier figures over, Ctrl-C
while the outputs are written still writes metrics.json and closes the session, and outputs are
written whole (no truncated file, no stray temporary file)."""
from __future__ import annotations

import json
import shutil

import pytest

from explorer import outputs
from explorer.run import RunSettings, explore
from explorer.session import read_session

SPHERE = dict(object="sphere", mesh_resolution=24, reach_samples=0)  # no reach breakdown: 9 s each


@pytest.fixture(scope="module")
def four_touches(tmp_path_factory):
    out = tmp_path_factory.mktemp("four")
    explore(RunSettings(touches=4, eval_every=1, **SPHERE), out)
    return out


def test_a_resumed_run_keeps_the_earlier_error_curve_and_adds_the_times(four_touches, tmp_path):
    out = tmp_path / "run"
    shutil.copytree(four_touches, out)
    before = json.loads((out / "metrics.json").read_text())
    assert before["error_curve"], "premise: the sphere gives 4 contacts in 4 touches"
    # The earlier part's blocked moves are counted on, whatever this part adds.
    before["blocked_moves"] = {"retract": 2, "on": {"table": 2}}
    (out / "metrics.json").write_text(json.dumps(before))

    after = explore(RunSettings(touches=6, eval_every=1, **SPHERE), out, resume=True).metrics
    assert json.loads((out / "metrics.json").read_text())["touches"] == after["touches"] == 6
    touches = [c["touches"] for c in after["error_curve"]]
    assert after["error_curve"][:len(before["error_curve"])] == before["error_curve"]
    assert touches == sorted(set(touches)) and touches[-2:] == [5, 6]
    for key in ("wall_time_s", "simulated_time_s"):
        assert after[key] > before[key], key
    assert after["simulated_time_s"] < 3.0 * before["simulated_time_s"]  # 6 touches, not 4 + 6
    for phase, seconds in before["phase_times_s"].items():
        assert after["phase_times_s"][phase] >= seconds, phase
    assert after["parts"] == 2
    assert after["blocked_moves"]["retract"] >= 2 and after["blocked_moves"]["on"]["table"] >= 2


def test_resuming_a_finished_run_loses_nothing(four_touches, tmp_path):
    out = tmp_path / "run"
    shutil.copytree(four_touches, out)
    before = json.loads((out / "metrics.json").read_text())
    after = explore(RunSettings(touches=4, eval_every=1, **SPHERE), out, resume=True).metrics
    assert after["error_curve"] == before["error_curve"]
    assert after["simulated_time_s"] >= before["simulated_time_s"] > 0.0
    assert after["wall_time_s"] >= before["wall_time_s"]
    assert after["position_rmse_mm"] == pytest.approx(before["position_rmse_mm"], rel=1e-6)


def test_ctrl_c_while_the_outputs_are_written_keeps_the_metrics_and_closes_the_session(tmp_path, monkeypatch):
    import explorer.run

    steps = []

    def interrupted(mesh, contacts, planner, n_samples, seed, progress=None):
        progress(1)
        raise KeyboardInterrupt

    monkeypatch.setattr(explorer.run, "reach_breakdown", interrupted)
    with pytest.raises(KeyboardInterrupt):
        explore(RunSettings(touches=2, eval_every=0, **dict(SPHERE, reach_samples=64)), tmp_path,
                status=lambda step, done, total: steps.append((step, done, total)))
    assert steps == [("reachable fraction", 1, 64)]
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert metrics["touches"] == 2 and "reachable_fraction" not in metrics
    assert "interrupted_while" in metrics and metrics["position_rmse_mm"] > 0.0
    session = read_session(tmp_path / "session")
    assert session.metadata["end_status"] != "open"
    assert (tmp_path / "reconstruction.ply").stat().st_size > 100


def test_the_command_reports_ctrl_c_in_one_line_and_exit_130(tmp_path, monkeypatch, capsys):
    import explorer.run
    from scripts.explore import main

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(explorer.run, "reach_breakdown", interrupted)
    out = tmp_path / "run"
    assert main(["--object", "sphere", "--touches", "1", "--out", str(out)]) == 130
    err = capsys.readouterr().err
    assert "interrupted: everything recorded so far is kept" in err and "--resume" in err
    assert "Traceback" not in err and "device" not in err
    assert (out / "metrics.json").is_file()


def test_outputs_are_written_whole_or_not_at_all(tmp_path):
    path = tmp_path / "metrics.json"
    outputs.write_json(path, {"a": 1})

    class Unwritable:
        def export(self, file_type):
            raise OSError(28, "No space left on device")

    with pytest.raises(OSError):
        outputs.export_mesh(Unwritable(), tmp_path / "reconstruction.ply")
    with pytest.raises(TypeError):
        outputs.write_json(path, {"a": object()})
    assert json.loads(path.read_text()) == {"a": 1}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["metrics.json"]


def test_a_full_disk_leaves_no_temporary_file_behind(tmp_path, monkeypatch):
    import os

    def full(fd):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "fsync", full)
    with pytest.raises(OSError, match="No space"):
        outputs.write_text(tmp_path / "reconstruction.ply", "ply")
    from explorer.session.line_files import write_atomically
    with pytest.raises(OSError, match="No space"):
        write_atomically(tmp_path / "metadata.json", b"{}")
    assert list(tmp_path.iterdir()) == []


def test_a_figure_that_fails_halfway_leaves_the_previous_png(tmp_path):
    from reconstruction.figures.canvas import new_figure, save_png

    path = tmp_path / "errors.png"
    figure = new_figure(2.0, 2.0)
    figure.add_subplot().plot([0, 1], [0, 1])
    save_png(figure, path)
    before = path.read_bytes()
    assert before.startswith(b"\x89PNG")

    def disk_full_halfway(target, **_):  # writes part of a PNG, then the disk is full
        if hasattr(target, "write"):
            target.write(b"\x89PNG half")
        else:
            with open(target, "wb") as handle:
                handle.write(b"\x89PNG half")
        raise OSError(28, "No space left on device")

    broken = new_figure(2.0, 2.0)
    broken.savefig = disk_full_halfway
    with pytest.raises(OSError, match="No space"):
        save_png(broken, path)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["errors.png"]


def test_blocked_move_counts_of_two_parts_add_up_key_by_key():
    from explorer.run import _summed_counts

    earlier = {"retract": 2, "rest": 1, "on": {"table": 1, "generated:bowl/0": 2}}
    later = {"retract": 1, "transfer": 3, "on": {"generated:bowl/0": 4}}
    assert _summed_counts(earlier, later) == {"retract": 3, "rest": 1, "transfer": 3,
                                              "on": {"table": 1, "generated:bowl/0": 6}}
    assert _summed_counts({}, later) == later
