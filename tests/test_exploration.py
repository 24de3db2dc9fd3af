"""Regression tests of the whole simulated exploration: coverage and error bounds on small budgets,
reproducibility, and that an interrupted run keeps its contacts."""
import json

import numpy as np
import pytest

from explorer.recording import read_contacts_csv
from explorer.run import RunSettings, explore


@pytest.fixture(scope="module")
def sphere_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("sphere")
    return explore(RunSettings(object="sphere", touches=8, seed=0, eval_every=4, mesh_resolution=64), out)


def test_sphere_exploration_covers_and_reconstructs(sphere_run):
    m = sphere_run.metrics
    assert m["contacts"] >= 7
    assert m["position_rmse_mm"] < 1.0
    assert m["normal_rmse_deg"] < 6.0
    assert m["contact_normal_error_mean_deg"] < 8.0
    # the closest face's normal lies in the normal cone, so the cone's error is never larger
    assert m["contact_normal_error_mean_deg"] <= m["contact_normal_error_closest_face_mean_deg"] + 1e-9
    assert m["contact_position_error_rms_mm"] < 1.0
    assert m["coverage"] > 0.06  # 8 contacts with 1 cm discs on a 5 cm sphere: about 0.1
    assert m["reachable_fraction"] >= 0.9


def test_outputs_are_written_in_the_object_frame(sphere_run):
    out = sphere_run.out_dir
    points, normals = read_contacts_csv(out / "contacts.csv")
    assert len(points) == sphere_run.metrics["contacts"]
    np.testing.assert_allclose(np.linalg.norm(points, axis=1), 0.05, atol=1.5e-3)
    assert np.all(np.sum(points * normals, axis=1) > 0.95 * 0.05)  # outward
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["completed"] is True
    assert [c["touches"] for c in metrics["error_curve"]] == [4, 8]
    for name in ("reconstruction.ply", "reconstruction_error.png", "error_vs_touches.png",
                 "potential_slice.png"):
        assert (out / name).stat().st_size > 1000, name


def test_runs_are_reproducible_from_the_seed(tmp_path):
    a = explore(RunSettings(object="sphere", touches=3, seed=5, eval_every=0, mesh_resolution=32, reach_samples=0),
                tmp_path / "a")
    b = explore(RunSettings(object="sphere", touches=3, seed=5, eval_every=0, mesh_resolution=32, reach_samples=0),
                tmp_path / "b")
    # the same seed on the same machine: the same bytes (README, "Reproducible")
    assert len(read_contacts_csv(a.out_dir / "contacts.csv")[0]) >= 1
    assert (a.out_dir / "contacts.csv").read_bytes() == (b.out_dir / "contacts.csv").read_bytes()
    assert ((a.out_dir / "session" / "readings.csv").read_bytes()
            == (b.out_dir / "session" / "readings.csv").read_bytes())


def test_an_interrupted_run_keeps_every_contact(tmp_path):
    seen = []

    def interrupt_after_three(record):
        seen.append(record)
        if len(seen) == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        explore(RunSettings(object="box", touches=10, seed=1, eval_every=0, mesh_resolution=32, reach_samples=0),
                tmp_path, interrupt_after_three)
    points, _ = read_contacts_csv(tmp_path / "contacts.csv")
    assert len(points) == sum(r.kind == "contact" for r in seen) >= 1
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert metrics["completed"] is False and metrics["touches"] == 3


def test_report_redraws_the_figures_from_the_run_directory(sphere_run, tmp_path):
    from explorer.report import write_report

    paths = write_report(sphere_run.out_dir, tmp_path / "report")
    names = {p.name for p in paths}
    assert {"reconstruction_error.png", "potential_slice.png", "error_vs_touches.png",
            "sensor_traces.png"} <= names
    for p in paths:
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and p.stat().st_size > 5000
    with pytest.raises(FileNotFoundError, match="not an exploration run"):
        write_report(tmp_path)
