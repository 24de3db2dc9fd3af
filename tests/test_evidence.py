"""What each kind of touch adds to the GPIS (explorer/evidence.py), checked against a GPIS given the
same rows directly."""
import numpy as np
import pytest

from explorer.evidence import SurfaceEvidence
from reconstruction.gpis import GPIS
from sensor.pad_calibration import PadCalibration

BOUNDS = (np.full(3, -0.1), np.full(3, 0.1))
POINTS = np.array([[0.04, 0.0, 0.0], [0.0, 0.04, 0.0], [0.0, 0.0, 0.04], [-0.04, 0.0, 0.0]])
PAD = np.array([0.0, 0.0, -0.05])   # a side press below the last contacts


def _queries():
    return np.random.default_rng(0).uniform(-0.08, 0.08, size=(200, 3))


def test_a_side_press_before_the_first_contact_waits_and_equals_the_rows_given_directly():
    evidence = SurfaceEvidence(GPIS(bounds=BOUNDS), -0.009, 0.005, side_press_value=-0.0065, side_press_noise=0.004)
    evidence.add_side_press(PAD)
    assert evidence.gpis.n_contacts == 0 and evidence.gpis.n_rows == 0
    for p in POINTS:
        evidence.add_contact(p, p / np.linalg.norm(p))
    direct = GPIS(bounds=BOUNDS)
    for p in POINTS[:1]:
        direct.add(p, p / np.linalg.norm(p))
    direct.add_values(PAD[None], np.array([-0.0065]), noise=0.004)
    for p in POINTS[1:]:
        direct.add(p, p / np.linalg.norm(p))
    np.testing.assert_allclose(evidence.gpis.mean(_queries()), direct.mean(_queries()), rtol=0, atol=1e-9)
    assert evidence.gpis.n_rows == 4 * len(POINTS) + 1


def test_a_side_press_pulls_the_field_towards_its_value_and_lowers_the_variance_there():
    def field(side_noise):
        evidence = SurfaceEvidence(GPIS(bounds=BOUNDS), -0.009, 0.005, -0.0065, side_noise)
        for p in POINTS:
            evidence.add_contact(p, p / np.linalg.norm(p))
        evidence.add_side_press(PAD)
        return evidence.gpis

    without, with_side = field(None), field(0.004)
    assert with_side.n_rows == without.n_rows + 1
    before, after = float(without.mean(PAD[None])[0]), float(with_side.mean(PAD[None])[0])
    assert abs(after - (-0.0065)) < abs(before - (-0.0065))
    assert float(with_side.variance(PAD[None])[0]) < float(without.variance(PAD[None])[0])
    assert float(with_side.variance(PAD[None])[0]) < 0.004 ** 2


def test_a_side_press_outside_the_bounds_adds_nothing():
    evidence = SurfaceEvidence(GPIS(bounds=BOUNDS), -0.009, 0.005, -0.0065, 0.004)
    evidence.add_contact(POINTS[0], np.array([1.0, 0.0, 0.0]))
    rows = evidence.gpis.n_rows
    evidence.add_side_press(np.array([0.0, 0.0, 0.2]))
    assert evidence.gpis.n_rows == rows


def _sphere_evidence():
    evidence = SurfaceEvidence(GPIS(bounds=BOUNDS), -0.009, 0.005, -0.0065, 0.004)
    for p in POINTS:
        evidence.add_contact(p, p / np.linalg.norm(p))
    return evidence


def test_swept_points_become_free_space_only_where_the_field_puts_surface_nearer():
    """A line from outside through the middle of four contacts on a 4 cm sphere: the points whose
    mean lies above the free-space value (inside, or within 9 mm outside) get a row each, pulled
    towards that value; the points the field already has far outside get none."""
    evidence = _sphere_evidence()
    line = np.column_stack([np.zeros(16), np.zeros(16), np.linspace(-0.09, 0.0, 16)])
    before = evidence.gpis.mean(line)
    disagree = before > -0.009
    assert 0 < disagree.sum() < len(line)   # both kinds on this line
    rows = evidence.gpis.n_rows
    evidence.add_swept(line)
    assert evidence.gpis.n_rows == rows + disagree.sum()
    after = evidence.gpis.mean(line)
    assert np.all(np.abs(after[disagree] + 0.009) < np.abs(before[disagree] + 0.009))
    direct = _sphere_evidence().gpis.add_values(line[disagree], np.full(disagree.sum(), -0.009), noise=0.005)
    np.testing.assert_allclose(after, direct.mean(line), rtol=0, atol=1e-12)


def test_swept_points_add_nothing_before_the_first_contact_or_outside_the_bounds():
    evidence = SurfaceEvidence(GPIS(bounds=BOUNDS), -0.009, 0.005, -0.0065, 0.004)
    evidence.add_swept(np.zeros((3, 3)))
    assert evidence.gpis.n_rows == 0
    evidence = _sphere_evidence()
    rows = evidence.gpis.n_rows
    evidence.add_swept(np.array([[0.0, 0.0, 0.15], [0.0, 0.0, -0.2]]))
    assert evidence.gpis.n_rows == rows


def test_the_swept_line_ends_a_margin_short_of_a_contact_or_a_side_press_and_is_empty_otherwise():
    from explorer.touch import TouchOutcome

    target, approach = np.array([0.0, 0.0, 0.05]), np.array([0.0, 0.0, -1.0])
    contact = TouchOutcome(0, "contact", target, approach, position_m=np.array([0.001, 0.0, 0.005]))
    line = contact.swept_points(0.009, spacing_m=0.01)
    np.testing.assert_allclose(line[:, 2], [0.05, 0.04, 0.03, 0.02])   # reached 45 mm, up to 36 mm
    np.testing.assert_allclose(line[:, :2], 0.0)
    side = TouchOutcome(1, "no_normal", target, approach, side_m=np.array([0.0, 0.0, 0.02]))
    np.testing.assert_allclose(side.swept_points(0.009)[:, 2], [0.05, 0.04, 0.03])   # reached 30 mm, up to 21
    for kind in ("realign", "miss", "blocked"):
        touch = TouchOutcome(2, kind, target, approach, position_m=np.array([0.0, 0.0, 0.0]))
        assert touch.swept_points(0.009).shape == (0, 3)
    assert TouchOutcome(3, "no_normal", target, approach).swept_points(0.009).shape == (0, 3)


def test_a_contact_far_past_its_target_frees_its_probe_corridor_in_the_field():
    """The pad went from a target inside the guessed sphere 7 cm down through it to a contact on
    the far side: with ``probe_corridor_m`` 3 cm its swept line joins the field through the gate,
    as :meth:`SurfaceEvidence.add_swept` adds it; a contact 2 cm past its target, or the option
    off, adds the contact alone."""
    from explorer.touch import TouchOutcome

    down = np.array([0.0, 0.0, -1.0])
    far = TouchOutcome(0, "contact", np.array([0.0, 0.0, 0.03]), down, position_m=np.array([0.0, 0.0, -0.04]),
                       normal=down)
    near = TouchOutcome(1, "contact", np.array([0.0, 0.0, -0.02]), down, position_m=np.array([0.0, 0.0, -0.04]),
                        normal=down)
    assert far.past_target_m() == pytest.approx(0.07) and near.past_target_m() == pytest.approx(0.02)

    def evidence(corridor_m):
        out = _sphere_evidence()
        out.probe_corridor_m = corridor_m
        return out

    on, off = evidence(0.03), evidence(None)
    rows = on.gpis.n_rows
    line = far.swept_points(0.009)
    inside = on.gpis.mean(line) > -0.009
    assert inside.sum() >= 3
    on.add_touch(far, doubtful_normal_noise=0.5)
    off.add_touch(far, doubtful_normal_noise=0.5)
    assert off.gpis.n_rows == rows + 4 and on.gpis.n_rows == rows + 4 + inside.sum()
    direct = _sphere_evidence()
    direct.add_contact(far.position_m, far.normal)
    direct.add_swept(line)
    np.testing.assert_allclose(on.gpis.mean(_queries()), direct.gpis.mean(_queries()), rtol=0, atol=1e-12)
    assert np.all(on.gpis.mean(line[inside]) < off.gpis.mean(line[inside]))
    short = evidence(0.03)
    short.add_touch(near, doubtful_normal_noise=0.5)
    assert short.gpis.n_rows == rows + 4
    assert on.rebuilt([far], doubtful_normal_noise=0.5).probe_corridor_m == 0.03


def _records():
    """A contact, a doubtful contact, a miss whose line runs from 3 cm outside the sphere's -y side
    to its surface, and a press on the pad's side, as the loop records them."""
    from explorer.contact import ContactQuality
    from explorer.touch import TouchOutcome

    down = np.array([0.0, 0.0, -1.0])
    doubtful = ContactQuality(force_n=2.0, n_readings=10, approach_cosine=0.9, tilt_rad=0.1,
                              pad_uv_m=np.zeros(2), rim_distance_m=0.001, doubtful=True)
    miss_line = np.column_stack([np.zeros(7), np.linspace(-0.07, -0.04, 7), np.zeros(7)])
    return [
        TouchOutcome(0, "contact", POINTS[2] + [0, 0, 0.02], down, position_m=POINTS[2], normal=-down),
        TouchOutcome(1, "contact", POINTS[0] + [0.02, 0, 0], np.array([-1.0, 0, 0]), position_m=POINTS[0],
                     normal=np.array([1.0, 0, 0]), quality=doubtful),
        TouchOutcome(2, "miss", miss_line[0], np.array([0.0, 1.0, 0.0]), free_space_m=miss_line),
        TouchOutcome(3, "no_normal", PAD + [0, 0, -0.02], -down, side_m=PAD),
        TouchOutcome(4, "contact", POINTS[1] + [0, 0.02, 0], np.array([0.0, -1.0, 0.0]), position_m=POINTS[1],
                     normal=np.array([0.0, 1.0, 0.0])),
    ]


def test_rebuilt_evidence_gives_back_the_field_the_touches_built_and_can_leave_the_misses_out():
    records = _records()
    live = SurfaceEvidence(GPIS(bounds=BOUNDS), -0.009, 0.005, -0.0065, 0.004)
    live.add_contact(records[0].position_m, records[0].normal)
    live.add_contact(records[1].position_m, records[1].normal, normal_noise=0.5)
    live.add_free_space(records[2].free_space_m)
    live.add_side_press(PAD)
    live.add_contact(records[4].position_m, records[4].normal)
    again = live.rebuilt(records, doubtful_normal_noise=0.5)
    assert again.gpis is not live.gpis and again.gpis.n_rows == live.gpis.n_rows == 3 * 4 + 7 + 1
    np.testing.assert_allclose(again.gpis.mean(_queries()), live.gpis.mean(_queries()), rtol=0, atol=1e-12)
    no_misses = live.rebuilt(records, doubtful_normal_noise=0.5, misses=False)
    assert no_misses.gpis.n_rows == live.gpis.n_rows - 7
    direct = SurfaceEvidence(GPIS(bounds=BOUNDS), -0.009, 0.005, -0.0065, 0.004)
    for i in (0, 1, 4):
        direct.add_contact(records[i].position_m, records[i].normal, normal_noise=0.5 if i == 1 else None)
        if i == 1:
            direct.add_side_press(PAD)
    np.testing.assert_allclose(no_misses.gpis.mean(_queries()), direct.gpis.mean(_queries()), rtol=0, atol=1e-12)


def test_an_unfitted_copy_has_the_settings_and_none_of_the_observations():
    gp = GPIS(bounds=BOUNDS, noise=1e-3, normal_noise=0.3, trend=2.0, opposing_normal_noise=0.1,
              opposing_radius_m=0.02).fit(POINTS, POINTS / np.linalg.norm(POINTS, axis=1, keepdims=True))
    copy = gp.unfitted_copy()
    assert copy.n_rows == 0 and copy.n_contacts == 0
    copy.fit(POINTS, POINTS / np.linalg.norm(POINTS, axis=1, keepdims=True))
    np.testing.assert_allclose(copy.mean(_queries()), gp.mean(_queries()), rtol=0, atol=1e-12)
    np.testing.assert_allclose(copy.variance(_queries()), gp.variance(_queries()), rtol=0, atol=1e-15)


def test_a_misss_row_where_the_field_is_already_free_pulls_the_surface_out_and_the_gate_leaves_it_out():
    """The miss of :func:`_records` ran towards the sphere's -y side, where nothing was touched. At
    its far points the field of the other touches already lies below the -9 mm its rows ask for, so
    the loop's rows raise the field there (pull the surface out towards the line); offered through
    the gate instead, those points get no row and the points the field puts nearer get one each."""
    from explorer.evidence import with_swept_free_space

    records = _records()
    template = SurfaceEvidence(GPIS(bounds=BOUNDS), -0.009, 0.005, -0.0065, 0.004)
    with_rows = template.rebuilt(records, 0.5).gpis
    without = template.rebuilt(records, 0.5, misses=False).gpis
    line = records[2].free_space_m
    free_already = without.mean(line) < -0.009
    assert 0 < free_already.sum() < len(line)
    pulled = with_rows.mean(line[free_already]) - without.mean(line[free_already])
    assert np.all(pulled > 0)   # raised towards -9 mm: the surface pulled out towards the line
    gated, rows = with_swept_free_space(without, records, -0.009, 0.002, misses=True)
    swept_rows = with_swept_free_space(without, records, -0.009, 0.002)[1]
    assert rows - swept_rows == np.count_nonzero(~free_already)
    moved_by_gate = np.abs(gated.mean(line[free_already]) - without.mean(line[free_already]))
    assert np.all(moved_by_gate < pulled)


def test_the_reconstruction_tightens_a_doubtful_contact_on_a_thin_wall_and_the_loops_field_does_not():
    """Two contacts on the faces of a 4 mm slab, the second doubtful. ``LoopConfig.reconstruction_field``
    rebuilds the field with ``GPIS.opposing_overrides_floor`` (``reconstruction_tightens_doubtful``):
    as if the second had not been doubted. ``reconstruction_doubtful_normal_noise`` alone sets its
    floor. The loop's field, and a session recorded before both settings, keep the loop's floor."""
    from dataclasses import replace

    from explorer.contact import ContactQuality
    from explorer.loop import LoopConfig
    from explorer.touch import TouchOutcome

    doubtful = ContactQuality(force_n=2.0, n_readings=10, approach_cosine=0.9, tilt_rad=0.1,
                              pad_uv_m=np.zeros(2), rim_distance_m=0.001, doubtful=True)
    up, down = np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, -1.0])
    top, bottom = np.array([0.0, 0.0, 0.002]), np.array([0.005, 0.0, -0.002])
    records = [TouchOutcome(0, "contact", top, down, position_m=top, normal=up),
               TouchOutcome(1, "contact", bottom, up, position_m=bottom, normal=down, quality=doubtful)]
    config = replace(LoopConfig(), reconstruction_wall_gain=None)   # both faces: the next test
    assert config.reconstruction_tightens_doubtful
    loop_field = config.evidence(GPIS(bounds=BOUNDS))
    for record in records:
        loop_field.add_touch(record, config.doubtful_normal_noise)
    field, rows = config.reconstruction_field(loop_field.gpis, records, PadCalibration())
    assert rows == 0 and not loop_field.gpis.opposing_overrides_floor
    undoubted = GPIS(bounds=BOUNDS)
    undoubted.add(top, up)
    undoubted.add(bottom, down)
    x = _queries()
    np.testing.assert_allclose(field.mean(x), undoubted.mean(x), rtol=0, atol=1e-9)
    legacy_config = replace(config, reconstruction_tightens_doubtful=False, reconstruction_doubtful_normal_noise=None)
    legacy, _ = legacy_config.reconstruction_field(loop_field.gpis, records, PadCalibration())
    np.testing.assert_allclose(legacy.mean(x), loop_field.gpis.mean(x), rtol=0, atol=1e-12)
    assert np.max(np.abs(legacy.mean(x) - field.mean(x))) > 1e-4
    floor_only, _ = replace(legacy_config, reconstruction_doubtful_normal_noise=0.3).reconstruction_field(
        loop_field.gpis, records, PadCalibration())
    direct = GPIS(bounds=BOUNDS)
    direct.add(top, up)
    direct.add(bottom, down, normal_noise=0.3)
    np.testing.assert_allclose(floor_only.mean(x), direct.mean(x), rtol=0, atol=1e-9)


def test_the_reconstruction_tightens_both_faces_of_a_thin_wall_whichever_was_touched_first():
    """The loop adds a slab's top face, then its bottom: only the bottom is tightened in the loop's
    field (the top had no opposing neighbour when it came). ``LoopConfig.reconstruction_field``
    with ``reconstruction_wall_gain`` gives the field one fit of both contacts gives, with that
    gradient gain; without it (sessions recorded before) the loop's field is the reconstruction's."""
    from dataclasses import replace

    from explorer.loop import LoopConfig
    from explorer.touch import TouchOutcome

    up, down = np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, -1.0])
    top, bottom = np.array([0.0, 0.0, 0.002]), np.array([0.005, 0.0, -0.002])
    records = [TouchOutcome(0, "contact", top, down, position_m=top, normal=up),
               TouchOutcome(1, "contact", bottom, up, position_m=bottom, normal=down)]
    config = LoopConfig()
    assert config.reconstruction_wall_gain is not None and config.reconstruction_wall_gain > 1
    loop_field = config.evidence(GPIS(bounds=BOUNDS))
    for record in records:
        loop_field.add_touch(record, config.doubtful_normal_noise)
    field, rows = config.reconstruction_field(loop_field.gpis, records, PadCalibration())
    assert rows == 0 and loop_field.gpis.opposing_gradient_gain == 1.0
    x = _queries()
    once = GPIS(bounds=BOUNDS, opposing_gradient_gain=config.reconstruction_wall_gain).fit(
        np.array([top, bottom]), np.array([up, down]))
    np.testing.assert_allclose(field.mean(x), once.mean(x), rtol=0, atol=1e-9)
    assert np.max(np.abs(field.mean(x) - loop_field.gpis.mean(x))) > 1e-4
    legacy, _ = replace(config, reconstruction_wall_gain=None).reconstruction_field(loop_field.gpis, records, PadCalibration())
    np.testing.assert_allclose(legacy.mean(x), loop_field.gpis.mean(x), rtol=0, atol=1e-12)
