"""A contact that stood off the surface on the pad's rim (explorer.rim_standoff), and the
reconstruction fitted without it (LoopConfig.reconstruction)."""
from dataclasses import replace

import numpy as np
import pytest
from fakes import session_recorded_without

from explorer.contact import ContactQuality
from explorer.loop import LoopConfig
from explorer.replay import SessionReplay
from explorer.rim_standoff import RimStandoff
from explorer.touch import TouchOutcome
from reconstruction.gpis import GPIS
from reconstruction.synthetic_contacts import sphere_contacts
from sensor.pad_calibration import PadCalibration

RADIUS_M = 0.05
HALF_WIDTH_M = 0.009
PAD = PadCalibration(half_width_m=HALF_WIDTH_M)  # no point compliance: no indentation
BOUNDS = ((-0.09, -0.09, -0.09), (0.09, 0.09, 0.09))


def _turned(normal: np.ndarray, angle_rad: float) -> np.ndarray:
    """``normal`` turned by ``angle_rad`` about an axis perpendicular to it."""
    side = np.cross(normal, [0.0, 0.0, 1.0] if abs(normal[2]) < 0.9 else [1.0, 0.0, 0.0])
    side /= np.linalg.norm(side)
    return np.cos(angle_rad) * normal + np.sin(angle_rad) * side


def _sphere_with(extra_points, extra_normals, n=60):
    points, normals = sphere_contacts(n, RADIUS_M, seed=4)
    points = np.vstack([points, extra_points])
    normals = np.vstack([normals, extra_normals])
    return GPIS(bounds=BOUNDS).fit(points, normals), n


def test_a_contact_off_the_surface_by_what_the_pads_rim_reaches_is_flagged_and_no_other():
    # Three contacts beside 60 on a sphere, each off the surface along the radius at a direction
    # no sphere contact is near: 7 mm off with a normal 65 deg off (the rim of a pad turned so
    # reaches 8.2 mm, plus the margin: flagged), 7 mm off with the surface's normal (a step: kept), 20 mm off with
    # the normal 65 deg off (beyond the rim's reach and the margin: a part the others do not know, kept).
    directions = np.array([[0.6, 0.0, 0.8], [-0.6, 0.0, 0.8], [0.0, 0.8, -0.6]])
    heights = np.array([0.007, 0.007, 0.020])
    turns = np.radians([65.0, 0.0, 65.0])
    extra_points = directions * (RADIUS_M + heights[:, None])
    extra_normals = np.array([_turned(d, t) for d, t in zip(directions, turns)])
    gpis, n = _sphere_with(extra_points, extra_normals)
    flagged = RimStandoff().standing_off(gpis, HALF_WIDTH_M)
    assert flagged.shape == (n + 3,)
    assert flagged.tolist() == [False] * n + [True, False, False]
    # the same contact with a pad whose rim cannot reach 7 mm at 65 deg, even with the margin: kept
    rule = RimStandoff()
    narrow = 0.5 * (0.007 - rule.reach_margin_m) / np.sin(np.radians(65.0))
    assert narrow > 0 and not rule.standing_off(gpis, narrow)[n]


def test_nothing_is_flagged_on_contacts_of_one_smooth_surface():
    points, normals = sphere_contacts(80, RADIUS_M, seed=5)
    gpis = GPIS(bounds=BOUNDS).fit(points, normals)
    assert not RimStandoff().standing_off(gpis, HALF_WIDTH_M).any()
    assert not RimStandoff().standing_off(GPIS(bounds=BOUNDS, use_normals=False).fit(points), HALF_WIDTH_M).any()


CENTRED = ContactQuality(force_n=1.5, n_readings=20, tilt_rad=float(np.radians(8.0)))


def _loop_inputs(points, normals):
    """A loop config, one contact record per point (pressed near the pad's centre) and the loop's
    field fitted to them, as the reconstruction takes them."""
    records = [TouchOutcome(i, "contact", p + 0.02 * q, -q, position_m=p, normal=q, quality=CENTRED)
               for i, (p, q) in enumerate(zip(points, normals))]
    config = LoopConfig(swept_free_space=False, bridge_concave_contacts=False)
    live = config.evidence(GPIS(bounds=BOUNDS))
    for record in records:
        live.add_contact(record.position_m, record.normal)
    return config, records, live


def test_the_reconstruction_leaves_the_standing_off_contact_out_and_counts_it():
    points, normals = sphere_contacts(60, RADIUS_M, seed=4)
    direction = np.array([0.6, 0.0, 0.8])
    points = np.vstack([points, direction * (RADIUS_M + 0.007)])
    normals = np.vstack([normals, _turned(direction, np.radians(65.0))])
    config, records, live = _loop_inputs(points, normals)

    built = config.reconstruction(live.gpis, records, PAD)
    assert built.rim_standoff_touches == (60,)
    assert built.field.n_contacts == 60 and live.gpis.n_contacts == 61  # the loop's field as measured
    np.testing.assert_allclose(built.field.contact_points, points[:60])
    on_surface = direction * RADIUS_M
    assert abs(built.field.mean(on_surface[None])[0]) < abs(live.gpis.mean(on_surface[None])[0])

    off = replace(config, reconstruction_sets_aside_rim_standoffs=False).reconstruction(live.gpis, records, PAD)
    assert off.rim_standoff_touches == () and off.field is live.gpis

    # The press must say the pad met the surface near its centre: a doubtful contact (placed at the
    # rim already), a spring turned far, or no quality at all keep the contact.
    for quality in (replace(CENTRED, doubtful=True), replace(CENTRED, tilt_rad=float(np.radians(30.0))), None):
        kept = records[:60] + [replace(records[60], quality=quality)]
        assert config.reconstruction(live.gpis, kept, PAD).rim_standoff_touches == ()


@pytest.mark.parametrize("field, value", [("min_depth_m", 0.0), ("min_angle_rad", 0.0), ("min_angle_rad", 4.0),
                                          ("reach_margin_m", -0.001), ("max_tilt_rad", 0.0)])
def test_bad_settings_are_refused_by_name(field, value):
    with pytest.raises(ValueError, match=field):
        RimStandoff(**{field: value})


def test_a_run_counts_what_it_set_aside_and_sessions_before_the_setting_replay_without_it(recorded_sphere_run, tmp_path):
    run = recorded_sphere_run
    assert run.metrics["rim_standoff_contacts"] == len(run.metrics["rim_standoff_touches"])
    if not run.metrics["rim_standoff_touches"]:
        assert run.metrics["contact_position_error_rms_kept_mm"] == run.metrics["contact_position_error_rms_mm"]
    assert SessionReplay(run.out_dir / "session").loop_config.reconstruction_sets_aside_rim_standoffs
    old = session_recorded_without(run.out_dir / "session", tmp_path / "old-session",
                                   "reconstruction_sets_aside_rim_standoffs")
    assert not SessionReplay(old).loop_config.reconstruction_sets_aside_rim_standoffs


def test_a_contact_hidden_by_a_standing_off_neighbour_is_found_in_the_next_round(monkeypatch):
    # Two contacts off the sphere 16 mm apart, 9 mm out with the normal 80 deg off and 7 mm out
    # with it 65 deg off: each holds the other's surface out, and only the first is set aside
    # until it is gone; the reconstruction's next round finds the second.
    import explorer.loop

    points, normals = sphere_contacts(60, RADIUS_M, seed=4)
    first = np.array([0.6, 0.0, 0.8])
    second = np.array([0.6, 0.6 * np.tan(np.radians(18.0)), 0.8])
    second /= np.linalg.norm(second)
    points = np.vstack([points, first * (RADIUS_M + 0.009), second * (RADIUS_M + 0.007)])
    normals = np.vstack([normals, _turned(first, np.radians(80.0)), _turned(second, np.radians(65.0))])
    config, records, live = _loop_inputs(points, normals)

    built = config.reconstruction(live.gpis, records, PAD)
    assert built.rim_standoff_touches == (60, 61) and built.field.n_contacts == 60
    monkeypatch.setattr(explorer.loop, "RIM_STANDOFF_ROUNDS", 1)
    assert config.reconstruction(live.gpis, records, PAD).rim_standoff_touches == (60,)


def test_the_contacts_error_over_those_kept_leaves_out_the_set_aside_ones_and_only_them():
    """On a box's top face, contacts 1, 2 and 3 mm above it and one 9 mm above: the RMS over all
    is sqrt((1 + 4 + 9 + 81) / 4) mm, over the three kept sqrt(14 / 3) mm (closed forms)."""
    import trimesh

    from explorer.evaluation import reconstruction_errors
    from explorer.outputs import kept_contacts

    box = trimesh.creation.box((0.1, 0.1, 0.02))
    heights = np.array([0.001, 0.002, 0.003, 0.009])
    points = np.column_stack([np.linspace(-0.03, 0.03, 4), np.zeros(4), 0.01 + heights])
    normals = np.tile([0.0, 0.0, 1.0], (4, 1))
    records = [TouchOutcome(i, "contact", p, -n) for i, (p, n) in zip((3, 5, 8, 13), zip(points, normals))]
    kept = kept_contacts(records, (13,))
    assert kept.tolist() == [True, True, True, False]
    errors = reconstruction_errors(box.copy(), box, points, normals, kept)
    assert errors["contact_position_error_rms_mm"] == pytest.approx(np.sqrt(95 / 4), abs=1e-9)
    assert errors["contact_position_error_rms_kept_mm"] == pytest.approx(np.sqrt(14 / 3), abs=1e-9)
    every = reconstruction_errors(box.copy(), box, points, normals)
    assert every["contact_position_error_rms_kept_mm"] == every["contact_position_error_rms_mm"]
    assert reconstruction_errors(box.copy(), box, points, normals, np.zeros(4, bool))[
        "contact_position_error_rms_kept_mm"] is None
    with pytest.raises(ValueError, match="kept must be one flag per contact"):
        reconstruction_errors(box.copy(), box, points, normals, kept[:3])
