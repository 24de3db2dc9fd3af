"""The reference-table command: bad input, the table's logic on given records, a quick real run,
and the calibration files it applies."""
from __future__ import annotations

import json
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from explorer.arm_calibration import read_arm_calibration
from explorer.reference_table import CALIBRATED, ROWS, columns, format_markdown, plan_jobs, rows_named
from explorer.sweep import SweepConfig
from scripts.reference_table import main


@pytest.mark.parametrize("argv, message", [
    (["--rows", "teapot"], "--rows: unknown rows"),
    (["--profiles", "perfect"], "--profiles: unknown"),
    (["--touches", "150"], "at most 100"),
])
def test_bad_arguments_are_usage_errors_naming_the_option(tmp_path, argv, message, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main([*argv, "--out", str(tmp_path / "out")])
    assert exit_info.value.code == 2 and message in capsys.readouterr().err
    assert not (tmp_path / "out").exists()  # nothing written


def test_rows_are_the_references_with_their_robots():
    assert [r.robot for r in rows_named(["coffee_can", "cereal_box", "flat", "bowl"])] == \
        ["armar6", "armar6", "armar6", "armar3"]
    assert {r.kind for r in ROWS[:4]} == {"simulation"} and ROWS[0].main_column == "datasheet-noise"
    assert ROWS[-1].main_column == CALIBRATED
    assert columns(("ideal", "hardware-like"), calibrated=True) == ("ideal", "hardware-like", CALIBRATED)
    assert columns(("ideal",), calibrated=True) == ("ideal",)


def test_markdown_compares_with_the_reference_and_with_the_exploration_without_normals():
    base = dict(kind="simulation", robot="armar3", object="box", reference_with_mm=2.7, reference_without_mm=5.2,
                touches=100, contacts=80)
    records = [dict(base, row="box", column="datasheet-noise", main=True, with_normals_mm=2.0, without_normals_mm=3.0,
                    without_normals_contacts=70, same_contacts_without_normals_mm=1.9),
               dict(base, row="box", column="ideal", main=False, with_normals_mm=1.5, without_normals_mm=None,
                    same_contacts_without_normals_mm=1.4),
               dict(base, row="box", column="hardware-like", main=False, missing="not finished")]
    text = format_markdown(records, ("ideal", "datasheet-noise", "hardware-like"), "test")
    main_line = next(line for line in text.splitlines() if line.startswith("| box | simulation"))
    # the verdict compares with the exploration without normals (3.00), not with the refit (1.90)
    assert main_line.endswith("| 80 / 70 | 2.00 | 3.00 | 1.90 | 2.70 / 5.20 | yes | yes |")
    assert "| box | armar3 | 1.50 / 1.40 | 2.00 / 1.90 | not finished |" in text
    unexplored = format_markdown([dict(records[0], without_normals_mm=None, without_normals_contacts=None)],
                                 ("datasheet-noise",), "test")
    assert next(line for line in unexplored.splitlines() if line.startswith("| box |")).endswith(
        "| 80 / - | 2.00 | - | 1.90 | 2.70 / 5.20 | yes | - |")


@pytest.mark.parametrize("explore_without", [True, False])
def test_only_main_columns_are_explored_without_normals(tmp_path, explore_without):
    rows = rows_named(["box", "bowl"])
    cols = ("datasheet-noise", "hardware-like")  # no calibration: the bowl's main column is hardware-like
    jobs, cells = plan_jobs(tmp_path, rows, cols, touches=5, seed=0, calibrations={}, eval_every=0,
                            mesh_resolution=16, explore_without_normals=explore_without)
    without = {(obj, col) for obj, col, normals in cells if not normals}
    assert without == ({("box", "datasheet-noise"), ("bowl", "hardware-like")} if explore_without else set())
    assert len([key for key in cells if key[2]]) == 4 and len(jobs) == len(cells)
    assert all(("nonormals" in str(cells[key])) != key[2] for key in cells)
    # main columns first, with normals before without
    first = [job.name for job in jobs][:4 if explore_without else 2]
    assert all(("box-variance" in n and "datasheet" in n) or ("bowl-variance" in n and "datasheet" not in n)
               for n in first)


def test_quick_mode_writes_a_well_formed_table_with_and_without_normals(tmp_path):
    out = tmp_path / "table"
    assert main(["--quick", "--out", str(out)]) == 0
    text = (out / "reference_table.md").read_text()
    assert "with normals (mm)" in text and "without normals, explored (mm)" in text
    data = json.loads((out / "reference_table.json").read_text())
    assert data["columns"] == ["datasheet-noise"] and not data["failures"]
    (record,) = data["records"]
    assert record["object"] == "sphere" and record["main"] and record["touches"] == 3
    for key in ("with_normals_mm", "without_normals_mm", "same_contacts_without_normals_mm"):
        assert isinstance(record[key], float) and math.isfinite(record[key]) and record[key] > 0.0
    # without normals is its own exploration, not the with-normals run refitted
    assert "nonormals" in record["without_normals_run"] and record["without_normals_run"] != record["run"]
    assert json.loads((Path(record["without_normals_run"]) / "metrics.json").read_text())["use_normals"] is False
    assert (record["reference_with_mm"], record["reference_without_mm"]) == (0.5, 1.9)
    # a second call finds the run finished and rebuilds the same table without running it again
    assert main(["--quick", "--out", str(out)]) == 0
    assert json.loads((out / "reference_table.json").read_text())["records"] == data["records"]
    assert main(["--quick", "--table-only", "--out", str(out)]) == 0  # runs nothing, reads what is there
    assert json.loads((out / "reference_table.json").read_text())["records"] == data["records"]


def test_calibration_files_are_checked_by_name(tmp_path):
    path = tmp_path / "joint_calibration.json"
    with pytest.raises(ValueError, match="calibration file not found"):
        read_arm_calibration(path)
    path.write_text(json.dumps({"robot": "armar6", "profile": "hardware-like", "seed": 0}))
    with pytest.raises(ValueError, match="missing fitted_offset_deg"):
        read_arm_calibration(path)
    path.write_text(json.dumps({"robot": "armar6", "profile": "hardware-like", "seed": 0,
                                "fitted_offset_deg": [0.1] * 8, "fitted_link_length_error_mm": {"elbow": 0.5}}))
    calibration = read_arm_calibration(path)
    assert calibration.link_length_error_m == {"elbow": 0.0005} and math.isclose(calibration.offset_rad[0],
                                                                                  math.radians(0.1))
    with pytest.raises(ValueError, match="a calibrated sweep runs that robot and that one seed"):
        SweepConfig(objects=("sphere",), strategies=("variance",), seeds=(0,), robot="armar3",
                    profile="hardware-like", calibration=str(path))


def test_a_calibrated_arm_with_fitted_link_lengths_keeps_its_model_readable(tmp_path):
    """The calibrated kinematics' URDF (links lengthened by the fit) must outlive ``calibrated_arm``:
    the planner reads its collision shapes when the run starts, and every calibrated run failed with
    FileNotFoundError once the calibration fitted link lengths. Its directory goes with the model."""
    import gc

    import robots
    from explorer.arm_calibration import ArmCalibration, calibrated_arm
    from robots.kinematics import ArmKinematics
    from robots.link_spheres import ArmSpheres

    spec = robots.load("armar6")
    nominal = ArmKinematics(spec)
    calibration = ArmCalibration("armar6", "hardware-like", 0, np.zeros(spec.dof), {"elbow": 0.002})
    robot, kinematics = calibrated_arm(SimpleNamespace(dof=spec.dof), nominal, calibration)
    gc.collect()
    urdf = Path(kinematics.spec.urdf_path)
    assert urdf.is_file() and urdf != Path(spec.urdf_path)
    ArmSpheres(kinematics, kinematics.link_names[1:4])  # reads the URDF again
    q = spec.home_q[None]
    shift = kinematics.forward_kinematics(q).position_m - nominal.forward_kinematics(q).position_m
    assert 0.0015 < np.linalg.norm(shift) < 0.0025  # the elbow link is 2 mm longer in the pad's chain
    del kinematics
    gc.collect()
    assert not urdf.exists()
