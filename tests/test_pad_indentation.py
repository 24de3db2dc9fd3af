"""A pad pressed on a ball sinks deeper than on a plate: the least curvature read from the contacts'
normals, the depth model against presses in the simulator, and the contacts put back on the surface."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from fakes import session_recorded_without

import robots
from explorer.loop import LoopConfig
from explorer.pad_indentation import PadIndentation
from explorer.replay import ReplaySettings, SessionReplay
from explorer.touch import TouchOutcome
from robots.pad_compliance import measure_pad_compliance_m_per_n, measure_pad_point_compliance_m_per_n
from sensor.oriented_contact import OrientedContact
from sensor.pad_calibration import PadCalibration

FLAT, POINT = 0.136e-3, 0.26e-3   # m/N, the default simulated pad's (robots.pad_compliance)
PAD = PadCalibration(compliance_m_per_n=FLAT, point_compliance_m_per_n=POINT)


def _sphere(n: int, radius_m: float, seed: int = 0):
    rng = np.random.default_rng(seed)
    normals = rng.normal(size=(n, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    return radius_m * normals, normals


def _cylinder(n: int, radius_m: float, seed: int = 0):
    rng = np.random.default_rng(seed)
    angle, z = rng.uniform(0, 2 * np.pi, n), rng.uniform(-0.05, 0.05, n)
    normals = np.c_[np.cos(angle), np.sin(angle), np.zeros(n)]
    return radius_m * normals + np.c_[np.zeros((n, 2)), z], normals


def _plane(n: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    return np.c_[rng.uniform(-0.05, 0.05, (n, 2)), np.zeros(n)], np.tile([0.0, 0.0, 1.0], (n, 1))


def test_the_least_curvature_is_a_balls_one_over_its_radius_and_none_on_a_cylinder_or_a_plane():
    rule = PadIndentation()
    for radius in (0.03, 0.05, 0.08):
        kappa = rule.least_curvatures(*_sphere(300, radius))
        assert np.median(kappa) == pytest.approx(1.0 / radius, rel=0.05)
    assert np.abs(np.median(rule.least_curvatures(*_cylinder(300, 0.04)))) < 1.0
    assert np.allclose(rule.least_curvatures(*_plane(100)), 0.0)
    # a saddle z = (x^2 - y^2) / (2 r) curves towards the pad in one direction: not convex
    rng = np.random.default_rng(1)
    xy = rng.uniform(-0.03, 0.03, (300, 2))
    r = 0.05
    points = np.c_[xy, (xy[:, 0] ** 2 - xy[:, 1] ** 2) / (2 * r)]
    normals = np.c_[-xy[:, 0] / r, xy[:, 1] / r, np.ones(300)]
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    assert np.median(rule.least_curvatures(points, normals)) < 0.0


def test_the_depth_follows_presses_on_mesh_balls_of_the_simulator():
    """The model ``f (c_flat + min(1, s / (c_point f)) (c_point - c_flat))`` against the pad's
    depth in the simulator on finely meshed balls whose sagitta over the face is larger and smaller
    than the compression, with the point compliance of a smooth ball (1 / k: one contact point)."""
    k = 3000.0
    pad = PadCalibration(compliance_m_per_n=0.121e-3, point_compliance_m_per_n=1.0 / k)
    rule = PadIndentation(bearing_radius_m=0.009)   # the face's half width: a smooth ball
    # (radius m, force N, depth m) from head-on presses on icospheres of 6 subdivisions (1 mm
    # edges) at 3 kN/m per contact point, armar3 (BENCHMARKS.md, "A pad on a ball sinks deeper")
    presses = [(0.05, 1.54, 0.504e-3), (0.05, 2.86, 0.894e-3), (0.08, 1.51, 0.469e-3),
               (0.08, 3.10, 0.681e-3), (0.15, 2.79, 0.592e-3)]
    for radius, force, depth in presses:
        n = int(4 * np.pi * radius**2 / 0.012**2)   # contacts about 12 mm apart
        points, normals = _sphere(n, radius)
        extra = rule.depths(points, normals, np.full(n, force), pad)
        predicted = force * pad.compliance_m_per_n + np.median(extra)
        assert predicted == pytest.approx(depth, abs=0.03e-3 * force)


def _records(points, normals, forces):
    return [TouchOutcome(i, "contact", p + 0.02 * n, -n, position_m=p, normal=n,
                         contact=OrientedContact(0.0, p, n, float(f)))
            for i, (p, n, f) in enumerate(zip(points, normals, forces))]


def test_contacts_sunk_on_a_ball_are_put_back_and_a_cylinder_and_a_plane_are_left_as_measured():
    rule = PadIndentation()
    forces = np.random.default_rng(2).uniform(1.5, 3.0, 200)
    points, normals = _sphere(200, 0.05)
    depth = rule.depths(points, normals, forces, PAD)
    assert np.all(depth > 0.0)
    sunk = points - depth[:, None] * normals   # where the flat compliance left them
    moved, count = rule.apply(_records(sunk, normals, forces), PAD)
    assert count == 200
    radii = np.linalg.norm([r.position_m for r in moved], axis=1)
    assert np.abs(radii - 0.05).max() < 0.02e-3   # the curvature of the sunk contacts differs a little
    assert np.abs(np.linalg.norm(sunk, axis=1) - 0.05).mean() > 0.1e-3
    for shape, bound in ((_cylinder(200, 0.04), 0.02e-3), (_plane(100), 1e-9)):
        records = _records(*shape, np.full(len(shape[0]), 2.0))
        out, _ = rule.apply(records, PAD)   # the cylinder's sampled neighbourhoods curve a little
        assert max(np.linalg.norm(a.position_m - b.position_m) for a, b in zip(out, records)) < bound
    unmeasured = dataclasses.replace(PAD, point_compliance_m_per_n=None)
    records = _records(sunk, normals, forces)
    assert rule.apply(records, unmeasured) == (records, 0)
    miss = TouchOutcome(300, "miss", np.zeros(3), np.array([0.0, 0.0, -1.0]))
    out, count = rule.apply(records + [miss], PAD)
    assert count == 200 and out[-1] is miss


def test_the_reconstruction_indents_with_the_setting_with_or_without_normals():
    points, normals = _sphere(120, 0.05)
    records = _records(points, normals, np.full(120, 2.0))
    config = LoopConfig(swept_free_space=False)
    taken, bridged, indented = config.reconstruction_records(records, PAD)
    assert indented == 120 and bridged == 0
    classic = config.reconstruction_records(records, PAD, use_normals=False)
    assert classic[2] == 120   # where the contact is: the classic GPIS takes it too
    np.testing.assert_array_equal([r.position_m for r in classic[0]], [r.position_m for r in taken])
    off = LoopConfig(swept_free_space=False, indent_convex_contacts=False)
    assert off.reconstruction_records(records, PAD) == (records, 0, 0)


def test_the_point_compliance_lies_between_one_vertex_and_three_of_the_flat_faces_four():
    spec = dataclasses.replace(robots.load("armar3"), pad_contact_stiffness_n_per_m=3000.0)
    flat, point = measure_pad_compliance_m_per_n(spec), measure_pad_point_compliance_m_per_n(spec)
    # one contact point of k gives 1 / k; the flat face's four give about 1.5 / (4 k) in this solver
    assert 1.2 * flat < point < 1.1 / 3000.0


def test_replay_indents_as_recorded_and_sessions_before_the_setting_do_not(recorded_sphere_run, tmp_path):
    run = recorded_sphere_run
    assert "indented_contacts" in run.metrics
    replay = SessionReplay(run.out_dir / "session")
    assert replay.loop_config.indent_convex_contacts
    assert replay.pad.point_compliance_m_per_n is not None
    old = session_recorded_without(run.out_dir / "session", tmp_path / "old-session", "indent_convex_contacts")
    before = SessionReplay(old)
    assert not before.loop_config.indent_convex_contacts
    assert before._loop_config(ReplaySettings(indent_convex_contacts=True)).indent_convex_contacts


def test_the_point_compliance_is_recorded_read_back_and_checked():
    assert PadCalibration.from_dict(PAD.as_dict()).point_compliance_m_per_n == pytest.approx(POINT)
    legacy = PAD.as_dict()
    del legacy["point_compliance_m_per_n"]   # a session recorded before it: not measured
    assert PadCalibration.from_dict(legacy).point_compliance_m_per_n is None
    with pytest.raises(ValueError, match="point_compliance_m_per_n"):
        PadCalibration(point_compliance_m_per_n=-1e-4)
