"""A flat pad bridges concave surfaces (issue 11): the height from the neighbours' normals against
closed forms (inside a sphere every pair's curvature is exactly 1 / R, so the sagitta over the
pad's reach is ``reach^2 / 2R``; outside it, on a plane and across a thin wall nothing moves), the
loop's reconstruction records, and replay of sessions recorded before the setting."""

import numpy as np
import pytest
from fakes import session_recorded_without

from explorer.loop import LoopConfig
from explorer.pad_bridging import PadBridging
from explorer.replay import ReplaySettings, SessionReplay
from explorer.touch import TouchOutcome
from reconstruction.gpis import GPIS
from sensor.pad_calibration import PadCalibration

HALF_WIDTH_M = 0.009
PAD = PadCalibration(half_width_m=HALF_WIDTH_M)  # no point compliance: no indentation
REACH_M = np.sqrt(2.0) * HALF_WIDTH_M


def _cap_points(radius_m: float, n: int = 40, spread_rad: float = 0.6, seed: int = 0) -> np.ndarray:
    """(n, 3) points on a spherical cap around -z of a sphere at the origin, metres."""
    rng = np.random.default_rng(seed)
    polar = spread_rad * np.sqrt(rng.uniform(size=n))
    azimuth = rng.uniform(0.0, 2.0 * np.pi, n)
    return radius_m * np.column_stack([np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth), -np.cos(polar)])


@pytest.mark.parametrize("radius_m", [0.06, 0.1])
def test_inside_a_sphere_every_contact_moves_in_by_the_sagitta_over_the_pads_reach(radius_m):
    points = _cap_points(radius_m)
    inward = -points / radius_m   # the outward normal of the hollow points to the centre
    heights = PadBridging().heights(points, inward, REACH_M)
    expected = 0.5 * REACH_M**2 / radius_m   # 1.34 mm at 60 mm, 0.81 mm at 100 mm
    has_neighbours = heights > 0.0
    assert has_neighbours.mean() > 0.9
    np.testing.assert_allclose(heights[has_neighbours], expected, rtol=1e-9)


def test_a_convex_surface_a_plane_and_a_thin_wall_are_left_as_measured():
    points = _cap_points(0.06)
    assert not PadBridging().heights(points, points / 0.06, REACH_M).any()   # outside the sphere
    rng = np.random.default_rng(1)
    plane = np.column_stack([rng.uniform(-0.05, 0.05, (60, 2)), np.zeros(60)])
    up = np.tile([0.0, 0.0, 1.0], (60, 1))
    assert not PadBridging().heights(plane, up, REACH_M).any()
    wall = np.vstack([plane, plane + [0.0, 0.0, -0.003]])   # both sides of a 3 mm plate
    normals = np.vstack([up, -up])
    assert not PadBridging().heights(wall, normals, REACH_M).any()


def test_a_tight_hollow_is_capped_and_a_contact_without_enough_neighbours_stays():
    points = _cap_points(0.02, n=30, spread_rad=1.0)
    heights = PadBridging().heights(points, -points / 0.02, REACH_M)   # sagitta 4 mm
    assert heights.max() == PadBridging().max_height_m
    lonely = np.array([[0.0, 0.0, -0.06], [0.05, 0.0, -0.04], [0.0, 0.05, -0.04]])
    assert not PadBridging().heights(lonely, -lonely / np.linalg.norm(lonely, axis=1)[:, None], REACH_M).any()


def test_apply_moves_only_the_bridged_contacts_along_their_normals():
    points = _cap_points(0.06, n=12, spread_rad=0.3)
    normals = -points / 0.06
    records = [TouchOutcome(i, "contact", p + 0.02 * n, -n, position_m=p, normal=n)
               for i, (p, n) in enumerate(zip(points, normals))]
    miss = TouchOutcome(len(records), "miss", np.zeros(3), np.array([0.0, 0.0, -1.0]))
    moved, count = PadBridging().apply(records + [miss], HALF_WIDTH_M)
    heights = PadBridging().heights(points, normals, REACH_M)
    assert count == np.count_nonzero(heights) > 0 and moved[-1] is miss
    for record, new, height in zip(records, moved, heights):
        np.testing.assert_allclose(new.position_m, record.position_m - height * record.normal, atol=1e-15)
        np.testing.assert_array_equal(new.normal, record.normal)
        assert (new is record) == (height == 0.0)


def test_the_reconstruction_takes_bridged_contacts_only_with_normals_and_the_setting():
    points = _cap_points(0.06, n=12, spread_rad=0.3)
    normals = -points / 0.06
    records = [TouchOutcome(i, "contact", p + 0.02 * n, -n, position_m=p, normal=n)
               for i, (p, n) in enumerate(zip(points, normals))]
    config = LoopConfig(swept_free_space=False)
    moved, count, _ = config.reconstruction_records(records, PAD)
    assert count > 0
    assert config.reconstruction_records(records, PAD, use_normals=False) == (records, 0, 0)
    off = LoopConfig(swept_free_space=False, bridge_concave_contacts=False)
    assert off.reconstruction_records(records, PAD) == (records, 0, 0)

    bounds = [[-0.08, -0.08, -0.08], [0.08, 0.08, 0.08]]
    live = config.evidence(GPIS(bounds=bounds))
    for record in records:
        live.add_contact(record.position_m, record.normal)
    field, rows = config.reconstruction_field(live.gpis, records, PAD)
    assert rows == 0 and field is not live.gpis
    np.testing.assert_allclose(field.contact_points, [r.position_m for r in moved])
    np.testing.assert_allclose(live.gpis.contact_points, points)   # the loop's field as measured
    assert off.reconstruction_field(live.gpis, records, PAD)[0] is live.gpis


def test_replay_bridges_as_recorded_and_sessions_before_the_setting_do_not(recorded_sphere_run, tmp_path):
    run = recorded_sphere_run
    assert "bridged_contacts" in run.metrics
    assert SessionReplay(run.out_dir / "session").loop_config.bridge_concave_contacts
    old = session_recorded_without(run.out_dir / "session", tmp_path / "old-session", "bridge_concave_contacts")
    before = SessionReplay(old)
    assert not before.loop_config.bridge_concave_contacts
    assert before._loop_config(ReplaySettings(bridge_concave_contacts=True)).bridge_concave_contacts
