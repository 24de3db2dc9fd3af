"""``scripts.calibration_poses``: the arm error a calibration leaves where an exploration went."""
from __future__ import annotations

import json

import numpy as np
import pytest

import robots
from robots.kinematics import ArmKinematics
from scripts import calibration_poses


@pytest.fixture(scope="module")
def armar6():
    return ArmKinematics(robots.load("armar6"))


def test_the_error_of_one_joint_offset_follows_the_jacobian(armar6):
    """An offset the calibration missed moves the pivot by the analytic Jacobian's column (pytorch
    kinematics) times the offset, to first order: an independent answer to the forward-kinematics
    difference the script takes."""
    spec = armar6.spec
    rng = np.random.default_rng(0)
    q = spec.home_q + 0.2 * rng.standard_normal((5, spec.dof))
    normals = rng.standard_normal((5, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    zero = np.zeros(spec.dof)
    assert np.allclose(calibration_poses.pivot_error_along_normal_m(armar6, q, normals, zero, {}, zero, {}), 0.0)
    for joint in (1, spec.dof - 1):
        offset = np.zeros(spec.dof)
        offset[joint] = 1e-5
        error = calibration_poses.pivot_error_along_normal_m(armar6, q, normals, offset, {}, zero, {})
        jacobian = armar6.jacobian(q, spec.pivot_link)[:, :3, joint]
        expected = 1e-5 * np.sum(jacobian * normals, axis=1)
        assert np.allclose(error, expected, atol=1e-10)  # second order: offset^2 x a 1 m lever
        fitted = calibration_poses.pivot_error_along_normal_m(armar6, q, normals, offset, {}, offset, {})
        assert np.allclose(fitted, 0.0, atol=1e-12)


def test_a_link_length_left_out_moves_the_pivot_by_that_length(armar6):
    q = np.tile(armar6.spec.home_q, (3, 1))
    axes = np.eye(3)
    zero = np.zeros(armar6.dof)
    error = calibration_poses.pivot_error_along_normal_m(armar6, q, axes, zero, {"elbow": 0.002}, zero, {})
    assert np.linalg.norm(error) == pytest.approx(0.002, rel=1e-9)  # its three components
    fitted = calibration_poses.pivot_error_along_normal_m(armar6, q, axes, zero, {"elbow": 0.002}, zero,
                                                          {"elbow": 0.002})
    assert np.allclose(fitted, 0.0, atol=1e-12)


def test_a_recorded_run_gives_its_contacts_configurations(recorded_sphere_run):
    from explorer.session import SessionReader

    robot, q_true, normals = calibration_poses.explored_configurations(recorded_sphere_run.out_dir)
    reader = SessionReader(recorded_sphere_run.out_dir / "session")
    contacts = reader.contacts()
    states = reader.joint_states()
    assert robot == "armar3" and q_true.shape == (len(contacts), states.q.shape[1]) and len(contacts) > 0
    # datasheet-noise has no encoder offsets and the run no calibration: the recorded angles themselves
    for row, contact in zip(q_true, contacts):
        assert any(np.allclose(row, q) for q in states.q[states.t_s >= contact.t_s][:1])
    assert np.allclose(np.linalg.norm(normals, axis=1), 1.0)


def test_the_script_scores_every_design(recorded_sphere_run, tmp_path, capsys):
    out = tmp_path / "poses.json"
    assert calibration_poses.main(["--explored", str(recorded_sphere_run.out_dir), "--seeds", "0",
                                   "--json", str(out)]) == 0
    results = json.loads(out.read_text())
    assert [(r["poses"], r["link_lengths"]) for r in results] == list(calibration_poses.DESIGNS)
    for r in results:
        assert r["robot"] == "armar3" and r["seeds"] == [0]
        assert 0.0 < r["rms_mm"][0] < 20.0 and abs(r["median_mm"][0]) < 20.0
    assert capsys.readouterr().out.count("| armar3 |") == len(calibration_poses.DESIGNS)


@pytest.mark.parametrize("extra, message", [(["--seeds", "a,b"], "comma-separated integers"),
                                            (["--seeds", ","], "at least one seed")])
def test_bad_options_are_refused_with_the_fix(recorded_sphere_run, extra, message, capsys):
    with pytest.raises(SystemExit) as exit_info:
        calibration_poses.main(["--explored", str(recorded_sphere_run.out_dir), *extra])
    assert exit_info.value.code == 2 and message in capsys.readouterr().err


def test_a_directory_that_is_not_a_run_is_refused(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        calibration_poses.main(["--explored", str(tmp_path)])
    assert exit_info.value.code == 2 and "not a run directory" in capsys.readouterr().err
