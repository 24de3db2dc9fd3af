"""What each kind of touch adds to the GPIS (explorer/evidence.py), checked against a GPIS given the
same rows directly."""
import numpy as np

from explorer.evidence import SurfaceEvidence
from reconstruction.gpis import GPIS

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
