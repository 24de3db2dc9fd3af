"""What a run's contact errors cost its reconstruction (issues 10 and 11): contacts made exact
against the truth (closed form on a box, and a second closest-point implementation on the recorded
sphere), the replay's refit of edited touches, and the script's figures and bad input."""
import json

import numpy as np
import pytest
import trimesh

from explorer.contact_truth import with_true_contacts
from explorer.replay import ReplaySettings, SessionReplay
from explorer.touch import TouchOutcome
from reconstruction.metrics import surface_error
from scripts import contact_error_cost


def _contact(index, position, normal, target=(0.0, 0.0, 0.1)):
    return TouchOutcome(index, "contact", np.asarray(target, float), np.array([0.0, 0.0, -1.0]),
                        position_m=np.asarray(position, float), normal=np.asarray(normal, float))


def test_contacts_worse_than_the_threshold_move_to_the_true_surface_and_the_rest_stay():
    box = trimesh.creation.box(extents=(0.1, 0.1, 0.1))  # top face at z = 0.05
    tilted = np.array([0.0, np.sin(0.5), np.cos(0.5)])
    far = _contact(0, (0.01, -0.02, 0.055), tilted)         # 5 mm over the top face
    near = _contact(1, (0.02, 0.01, 0.051), tilted)         # 1 mm over it
    miss = TouchOutcome(2, "miss", np.zeros(3), np.array([1.0, 0.0, 0.0]))
    out, changed = with_true_contacts([far, near, miss], box, worse_than_m=0.003)
    assert changed == 1 and len(out) == 3
    np.testing.assert_allclose(out[0].position_m, [0.01, -0.02, 0.05], atol=1e-12)
    np.testing.assert_allclose(out[0].normal, [0.0, 0.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(out[0].target_m, far.target_m)
    assert out[1] is near and out[2] is miss
    np.testing.assert_allclose(far.position_m, [0.01, -0.02, 0.055])  # the record itself is not changed

    left, changed = with_true_contacts([far, near, miss], box, worse_than_m=0.003, leave_out=True)
    assert changed == 1 and left == [near, miss]
    every, changed = with_true_contacts([far, near, miss], box)
    assert changed == 2 and every[1].position_m[2] == pytest.approx(0.05, abs=1e-12)
    placed, _ = with_true_contacts([far], box, positions=True, normals=False)
    np.testing.assert_allclose(placed[0].position_m, [0.01, -0.02, 0.05], atol=1e-12)
    np.testing.assert_allclose(placed[0].normal, tilted)
    turned, _ = with_true_contacts([far], box, positions=False, normals=True)
    np.testing.assert_allclose(turned[0].position_m, far.position_m)
    np.testing.assert_allclose(turned[0].normal, [0.0, 0.0, 1.0], atol=1e-12)
    with pytest.raises(ValueError, match="worse_than_m"):
        with_true_contacts([far], box, worse_than_m=-1.0)


@pytest.fixture(scope="module")
def sphere_run(recorded_sphere_run):
    return recorded_sphere_run


def test_the_refit_of_the_replayed_touches_is_the_run_and_exact_contacts_lie_on_the_truth(sphere_run):
    replay = SessionReplay(sphere_run.out_dir / "session")
    touches = replay.run(ReplaySettings(figures=False)).touches
    mesh = replay.refit(touches).mesh(resolution=replay.mesh_resolution(),
                                      refine_steps=replay.loop_config.reconstruction_refine_steps)
    assert surface_error(mesh, replay.truth).position_rmse_mm == pytest.approx(
        sphere_run.metrics["position_rmse_mm"], rel=1e-9)

    exact, changed = with_true_contacts(touches, replay.truth)
    assert changed == sphere_run.metrics["contacts"]
    field = replay.refit(exact)
    distance = trimesh.proximity.closest_point(replay.truth, field.contact_points)[1]  # trimesh's own search
    assert np.max(distance) < 1e-9


def test_the_script_counts_the_bad_contacts_and_reports_the_run_as_recorded(sphere_run, tmp_path, capsys):
    points = np.loadtxt(sphere_run.out_dir / "contacts.csv", delimiter=",", skiprows=1, usecols=(1, 2, 3), ndmin=2)
    truth = SessionReplay(sphere_run.out_dir / "session").truth
    distance_mm = 1e3 * trimesh.proximity.closest_point(truth, points)[1]
    threshold = float(np.median(distance_mm))  # half the contacts either side, whatever this machine measured
    out = tmp_path / "cost.json"
    assert contact_error_cost.main([str(sphere_run.out_dir), "--worse-than", str(threshold), "--json", str(out)]) == 0
    figures = json.loads(out.read_text())
    row = figures["runs"][0]
    assert row["contacts"] == len(points)
    assert row["bad_contacts"] == int(np.sum(distance_mm > threshold))
    assert row["rmse_mm"]["recorded"] == pytest.approx(sphere_run.metrics["position_rmse_mm"], rel=1e-9)
    assert all(row["rmse_mm"][v] is not None for v in contact_error_cost.VARIANTS)
    printed = capsys.readouterr().out
    assert f"| {sphere_run.out_dir.name} | sphere | {len(points)} |" in printed and "mean of 1 runs" in printed


@pytest.mark.parametrize("argv, message", [
    (["--worse-than", "0"], "--worse-than must be positive millimetres"),
    (["--mesh-resolution", "4"], "--mesh-resolution must be at least 8"),
])
def test_the_script_refuses_bad_options(sphere_run, capsys, argv, message):
    with pytest.raises(SystemExit) as exit_info:
        contact_error_cost.main([str(sphere_run.out_dir), *argv])
    assert exit_info.value.code == 2
    assert message in capsys.readouterr().err


def test_the_script_refuses_a_directory_without_a_run(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        contact_error_cost.main([str(tmp_path)])
    assert exit_info.value.code == 2
    assert "not a run directory" in capsys.readouterr().err
