"""Benchmark sweeps: process pool and Ray give the same table, resumption reruns only what is
missing, a failing run is recorded and the sweep goes on, the summary matches the table."""
import csv
import dataclasses
import json
import math
import shutil
import statistics
import sys

import pytest

from explorer.sweep import (SweepConfig, is_complete, plan_runs, read_csv, run_in_pool, run_on_ray,
                            run_sweep, touches_to_reach)
from explorer.sweep.plan import prepare_sweep_dir
from scripts.sweep import main as sweep_main

# Tiny runs (about 8 s each): 4 touches evaluated at touch 4 (the error curve needs 4 contacts),
# no reach breakdown (it would double that).
TINY = dict(strategies=("random",), seeds=(0, 1), touches=4, eval_every=2, mesh_resolution=24, reach_samples=0)
SPHERE_RUNS = ("sphere-random-normals-seed0", "sphere-random-normals-seed1")
BROKEN_RUNS = ("broken-random-normals-seed0", "broken-random-normals-seed1")


@pytest.fixture(scope="module")
def broken_mesh(tmp_path_factory):
    """A mesh file that passes the sweep's checks (it exists, .stl) but fails inside the run."""
    path = tmp_path_factory.mktemp("meshes") / "broken.stl"
    path.write_text("solid nothing\nendsolid nothing\n")
    return path


@pytest.fixture(scope="module")
def pool_sweep(tmp_path_factory, broken_mesh):
    out = tmp_path_factory.mktemp("pool")
    config = SweepConfig(objects=("sphere", str(broken_mesh)), **TINY)
    return config, run_sweep(config, out, workers=2, show_progress=False)


def _without_wall_time(rows):
    return [{k: v for k, v in row.items() if k != "wall_time_s"} for row in rows]


def test_a_failing_run_is_recorded_and_the_others_finish(pool_sweep):
    _, report = pool_sweep
    rows = {r["run"]: r for r in report.rows}
    assert set(rows) == set(SPHERE_RUNS + BROKEN_RUNS)
    for name in SPHERE_RUNS:
        assert rows[name]["completed"] and rows[name]["error"] is None
        assert rows[name]["touches"] == 4 and rows[name]["contacts"] >= 3
        assert 0 < rows[name]["position_rmse_mm"] < 3.0
        assert 0 < rows[name]["chamfer_l1_mm"] < 3.0 and 0 < rows[name]["fscore_5mm"] <= 1.0
        assert rows[name]["touches_to_3mm"] == 4
        metrics = json.loads((report.out_dir / "runs" / name / "metrics.json").read_text())
        assert "reach_breakdown" not in metrics  # the sweep's reach_samples=0 reached the run
    for name in BROKEN_RUNS:
        assert not rows[name]["completed"]
        assert rows[name]["error"].startswith("ValueError") and "broken.stl" in rows[name]["error"]
        assert rows[name]["position_rmse_mm"] is None
    failures = json.loads(report.failures_path.read_text())
    assert sorted(f["run"] for f in failures) == sorted(BROKEN_RUNS)
    assert all("Traceback" in f["traceback"] and "objects" in f["traceback"] for f in failures)
    markdown = report.markdown_path.read_text()
    assert all(f"`{name}`" in markdown for name in BROKEN_RUNS)


def test_error_figures_are_written_for_objects_with_finished_runs(pool_sweep):
    _, report = pool_sweep
    names = sorted(p.name for p in report.figures)
    assert names == ["sphere_normal_error.png", "sphere_position_error.png"]
    assert all(p.stat().st_size > 5000 for p in report.figures)


def test_ray_gives_the_same_table_as_the_process_pool(pool_sweep, tmp_path):
    pytest.importorskip("ray", reason="ray is an optional extra: pip install 'tactile-explore[ray]'")
    config, pool_report = pool_sweep
    ray_report = run_sweep(config, tmp_path, workers=2, ray_address="local", show_progress=False)
    assert sorted(ray_report.executed) == sorted(pool_report.executed)
    assert _without_wall_time(ray_report.rows) == _without_wall_time(pool_report.rows)
    assert all(r["wall_time_s"] > 0 for r in ray_report.rows if r["completed"])


def test_a_restarted_sweep_runs_only_the_missing_runs(pool_sweep, tmp_path):
    config, first = pool_sweep
    out = tmp_path / "sweep"
    shutil.copytree(first.out_dir, out)
    kept = out / "runs" / SPHERE_RUNS[0] / "metrics.json"
    kept_mtime = kept.stat().st_mtime_ns
    (out / "runs" / SPHERE_RUNS[1] / "metrics.json").unlink()
    assert not is_complete(out / "runs" / SPHERE_RUNS[1])

    again = run_sweep(config, out, workers=1, show_progress=False)
    assert again.skipped == [SPHERE_RUNS[0]]
    assert sorted(again.executed) == sorted((SPHERE_RUNS[1],) + BROKEN_RUNS)  # failures are retried
    assert kept.stat().st_mtime_ns == kept_mtime
    assert is_complete(out / "runs" / SPHERE_RUNS[1])
    # Runs are deterministic given the seed: the redone run reproduces its numbers.
    assert _without_wall_time(again.rows) == _without_wall_time(first.rows)


def test_the_summary_equals_statistics_computed_from_the_csv(pool_sweep):
    _, report = pool_sweep
    with open(report.csv_path, newline="") as handle:
        finished = [r for r in csv.DictReader(handle) if r["object"] == "sphere" and r["completed"] == "true"]
    position = [float(r["position_rmse_mm"]) for r in finished]
    angle = [float(r["normal_rmse_deg"]) for r in finished]
    coverage = [float(r["coverage"]) for r in finished]
    reached = [float(r["touches_to_3mm"]) for r in finished if r["touches_to_3mm"]]
    reached_2mm = [float(r["touches_to_2mm"]) for r in finished if r["touches_to_2mm"]]
    assert len(finished) == 2 and statistics.pstdev(position) > 0
    def mean_of(key, digits):
        return f"{statistics.fmean(float(r[key]) for r in finished):.{digits}f}"

    expected = ["sphere", "random", "yes", "2/2",
                f"{statistics.fmean(position):.2f} +- {statistics.pstdev(position):.2f}",
                f"{statistics.fmean(angle):.1f} +- {statistics.pstdev(angle):.1f}",
                mean_of("chamfer_l1_mm", 2), mean_of("chamfer_l2_mm", 2), mean_of("fscore_1mm", 3),
                mean_of("fscore_2mm", 3), mean_of("fscore_5mm", 3), mean_of("normal_consistency", 3),
                f"{statistics.fmean(coverage):.3f}", mean_of("extra_handles", 1),
                f"{statistics.fmean(reached):.1f} (2/2)",
                (f"{statistics.fmean(reached_2mm):.1f}" if reached_2mm else "-") + f" ({len(reached_2mm)}/2)"]
    table = [line.strip("|").split("|") for line in report.markdown_path.read_text().splitlines()
             if line.startswith("| sphere ")]
    assert [[cell.strip() for cell in row] for row in table] == [expected]


def test_the_command_line_finishes_nothing_twice_and_prints_the_summary(pool_sweep, tmp_path, capsys):
    _, first = pool_sweep
    out = tmp_path / "sweep"
    shutil.copytree(first.out_dir, out)
    code = sweep_main(["--objects", "sphere", "--strategies", "random", "--seeds", "2", "--touches", "4",
                       "--eval-every", "2", "--mesh-resolution", "24", "--out", str(out)])
    printed = capsys.readouterr().out
    assert code == 0
    assert "0 runs executed, 2 already finished, 0 failed" in printed
    assert "| sphere | random | yes | 2/2 |" in printed
    assert [r["run"] for r in read_csv(out / "sweep.csv")] == list(SPHERE_RUNS)


def test_the_command_line_rejects_bad_arguments(tmp_path, capsys):
    for args, message in ((["--strategies", "greedy"], "unknown strategy 'greedy'"),
                          (["--objects", "teapot"], "unknown object 'teapot'"),
                          (["--seeds", "0"], "--seeds must be at least 1"),
                          (["--first-seed", "-1"], "--first-seed must be >= 0"),
                          (["--reach-samples", "-1"], "argument --reach-samples: must be at least 0, got -1"),
                          (["--objects", "sphere,,box"], "empty name")):
        with pytest.raises(SystemExit) as exit_info:
            sweep_main(args + ["--out", str(tmp_path)])
        assert exit_info.value.code == 2
        assert message in capsys.readouterr().err


def test_the_plan_covers_the_grid_with_one_directory_per_run():
    config = SweepConfig(objects=("sphere", "box"), strategies=("random", "variance"), seeds=(0, 1, 2),
                         normals=(True, False))
    runs = plan_runs(config)
    assert len(runs) == 2 * 2 * 2 * 3
    assert len({r.name for r in runs}) == len(runs)
    assert runs[0].name == "sphere-random-normals-seed0"
    assert runs[-1].name == "box-variance-nonormals-seed2"
    settings = runs[-1].settings(config)
    assert (settings.object, settings.strategy, settings.use_normals, settings.seed, settings.touches) == (
        "box", "variance", False, 2, 50)
    assert settings.reach_samples == 64
    assert runs[0].settings(dataclasses.replace(config, reach_samples=0)).reach_samples == 0


@pytest.mark.parametrize("change, message", [
    (dict(strategies=("greedy",)), "unknown strategy"),
    (dict(objects=("teapot",)), "unknown object"),
    (dict(robot="r2d2"), "unknown robot"),
    (dict(seeds=(0, 0)), "seeds holds duplicates"),
    (dict(seeds=(-1,)), "non-negative"),
    (dict(objects="sphere"), "objects must be a non-empty sequence"),
    (dict(touches=0), "touches must be an integer >= 1"),
    (dict(normals=(1,)), "normals must be booleans"),
    (dict(reach_samples=-1), "reach_samples must be an integer >= 0"),
])
def test_bad_sweep_configurations_are_refused(change, message):
    arguments = dict(objects=("sphere",), strategies=("random",), seeds=(0,)) | change
    with pytest.raises(ValueError, match=message):
        SweepConfig(**arguments)


def test_mesh_files_with_the_same_stem_are_refused(tmp_path):
    for folder in ("a", "b"):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "cup.stl").write_text("solid cup\nendsolid cup\n")
    with pytest.raises(ValueError, match="clashing run names"):
        SweepConfig(objects=(str(tmp_path / "a/cup.stl"), str(tmp_path / "b/cup.stl")),
                    strategies=("random",), seeds=(0,))


def test_a_directory_swept_with_other_shared_settings_is_refused(tmp_path):
    prepare_sweep_dir(tmp_path, SweepConfig(objects=("sphere",), strategies=("random",), seeds=(0,),
                                            touches=10))
    extended = SweepConfig(objects=("sphere", "box"), strategies=("random",), seeds=(0, 1), touches=10)
    prepare_sweep_dir(tmp_path, extended)  # a larger grid with the same budget may reuse the runs
    with pytest.raises(ValueError, match="touches=10 there, 20 now"):
        prepare_sweep_dir(tmp_path, SweepConfig(objects=("sphere",), strategies=("random",), seeds=(0,),
                                                touches=20))


def test_a_sweep_moved_with_its_calibration_is_the_same_sweep_and_another_calibration_is_not(tmp_path):
    import json
    import shutil

    def calibrated(directory, offset_deg):
        path = directory / "joint_calibration.json"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps({"robot": "armar6", "profile": "hardware-like", "seed": 0,
                                    "fitted_offset_deg": [offset_deg] * 8}))
        return SweepConfig(objects=("sphere",), strategies=("random",), seeds=(0,), robot="armar6",
                           profile="hardware-like", calibration=str(path))

    first = tmp_path / "first"
    prepare_sweep_dir(first / "sweep", calibrated(first / "calibration", 0.1))
    shutil.copytree(first, tmp_path / "copy")
    prepare_sweep_dir(tmp_path / "copy" / "sweep", calibrated(tmp_path / "copy" / "calibration", 0.1))
    shutil.move(first, tmp_path / "moved")  # the recorded path is gone: the recorded digest decides
    prepare_sweep_dir(tmp_path / "moved" / "sweep", calibrated(tmp_path / "moved" / "calibration", 0.1))
    with pytest.raises(ValueError, match="calibration="):
        prepare_sweep_dir(tmp_path / "moved" / "sweep", calibrated(tmp_path / "other", 0.2))


@pytest.mark.parametrize("content, complete", [
    (None, False), ("{\"completed\": true}", True), ("{\"completed\": false}", False),
    ("{\"completed\": tr", False), ("{}", False), ("{\"completed\": \"true\"}", False)])
def test_only_a_metrics_file_saying_completed_counts_as_done(tmp_path, content, complete):
    if content is not None:
        (tmp_path / "metrics.json").write_text(content)
    assert is_complete(tmp_path) is complete


def test_touches_to_reach_takes_the_first_evaluation_at_or_below_the_target():
    def curve(*pairs):
        return [dict(touches=n, position_rmse_mm=e, normal_rmse_deg=0.0) for n, e in pairs]

    assert touches_to_reach(curve((5, 4.0), (10, 3.0), (15, 2.0))) == 10  # at the target counts
    assert touches_to_reach(curve((15, 2.0), (5, 4.0), (10, 2.5))) == 10  # in touch order
    assert touches_to_reach(curve((5, 2.0), (10, 3.5))) == 5  # first reach, even if it worsens
    assert touches_to_reach(curve((5, 3.01), (10, 4.0))) is None
    assert touches_to_reach([]) is None
    assert touches_to_reach(curve((5, 1.5)), target_mm=1.0) is None


def test_pool_refuses_fork_and_ray_names_its_install_command(monkeypatch):
    with pytest.raises(ValueError, match="not fork-safe"):
        run_in_pool([object()], 1, print, start_method="fork")
    with pytest.raises(ValueError, match="workers must be at least 1"):
        run_in_pool([object()], 0, print)
    monkeypatch.setitem(sys.modules, "ray", None)
    with pytest.raises(ImportError, match=r"pip install 'tactile-explore\[ray\]'"):
        run_on_ray([object()], "local", 2, print)


def test_no_finished_seed_gives_no_statistics():
    from explorer.sweep import summarise

    rows = [dict(object="box", strategy="random", normals=True, completed=False, position_rmse_mm=None,
                 normal_rmse_deg=None, coverage=None, touches_to_3mm=None)]
    (summary,) = summarise(rows)
    assert (summary.runs, summary.completed, summary.reached_target) == (1, 0, 0)
    assert math.isnan(summary.position_rmse_mm_mean) and math.isnan(summary.touches_to_target_mean)


def test_an_interrupted_pool_stops_its_workers_without_finishing_queued_runs(broken_mesh, tmp_path):
    import multiprocessing

    from explorer.sweep import RunJob
    from explorer.run import RunSettings

    jobs = [RunJob("broken", RunSettings(object=str(broken_mesh), touches=4), tmp_path / "broken"),
            RunJob("sphere", RunSettings(object="sphere", touches=4, eval_every=0, mesh_resolution=24),
                   tmp_path / "sphere")]

    def interrupt(outcome):
        assert outcome.name == "broken" and "ValueError" in outcome.error
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_in_pool(jobs, 1, interrupt)
    assert multiprocessing.active_children() == []
    assert not is_complete(tmp_path / "sphere")  # queued to the worker, but not run to the end


def test_touches_to_reach_takes_the_first_evaluation_at_or_below_each_level():
    """A synthetic error curve (given out of order): 3 mm is first reached at 20 touches, 2 mm at
    40 although the curve rises above 2 mm again afterwards; 1 mm never."""
    from explorer.sweep import SECOND_TARGET_RMSE_MM, TARGET_RMSE_MM, touches_to_reach

    errors = {10: 5.0, 20: 3.0, 30: 2.4, 40: 1.9, 50: 2.2, 60: 1.5}
    curve = [dict(touches=n, position_rmse_mm=e, normal_rmse_deg=0.0) for n, e in reversed(errors.items())]
    assert touches_to_reach(curve, TARGET_RMSE_MM) == 20
    assert touches_to_reach(curve, SECOND_TARGET_RMSE_MM) == 40
    assert touches_to_reach(curve, 1.0) is None
    assert touches_to_reach([], 3.0) is None
