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
