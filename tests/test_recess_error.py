"""The recess split of the surface error, against closed forms on a box with a square pocket."""
from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from reconstruction.metrics import recess_error

OUTER = (0.16, 0.16, 0.08)  # metres, centred at the origin: top face at z = 0.04
POCKET_WIDTH, POCKET_DEPTH = 0.06, 0.03


@pytest.fixture(scope="module")
def pocketed():
    """A 160 x 160 x 80 mm box with a 60 x 60 mm pocket 30 mm deep in its top, and the box filled."""
    solid = trimesh.creation.box(OUTER)
    cutter = trimesh.creation.box((POCKET_WIDTH, POCKET_WIDTH, 2 * POCKET_DEPTH))
    cutter.apply_translation((0.0, 0.0, OUTER[2] / 2))
    return trimesh.boolean.difference([solid, cutter], engine="manifold"), solid


def test_a_filled_pocket_is_all_recess_error_in_closed_form(pocketed):
    truth, filled = pocketed
    error = recess_error(filled, truth, n_samples=20000)
    w, d = POCKET_WIDTH, POCKET_DEPTH
    recess_area = w * w + 4 * w * d
    total_area = 2 * OUTER[0] * OUTER[1] + 4 * OUTER[0] * OUTER[2] - w * w + recess_area
    assert error.recess_fraction == pytest.approx(recess_area / total_area, abs=0.008)
    # floor samples are d from the filled top, a wall sample at depth s is s from it (sides >= 50 mm away)
    expected_mm = 1e3 * math.sqrt((w * w * d * d + 4 * w * d ** 3 / 3) / recess_area)
    assert error.recess_rmse_mm == pytest.approx(expected_mm, rel=0.03)
    assert error.open_rmse_mm < 1e-3  # the outside and the rim lie on the filled box
    assert error.recess_coverage is None and error.open_coverage is None


def test_the_truth_itself_has_no_error_and_coverage_follows_the_contacts(pocketed):
    truth, _ = pocketed
    rim = np.array([[0.06, 0.0, OUTER[2] / 2]])
    floor = np.array([[0.0, 0.0, OUTER[2] / 2 - POCKET_DEPTH]])
    on_rim = recess_error(truth, truth, contacts_m=rim, n_samples=20000)
    assert on_rim.recess_rmse_mm < 1e-3 and on_rim.open_rmse_mm < 1e-3
    assert on_rim.recess_coverage == 0.0 and on_rim.open_coverage > 0.0
    # a disc of 10 mm on the pocket's floor, 30 mm from its walls
    on_floor = recess_error(truth, truth, contacts_m=floor, n_samples=20000)
    recess_area = POCKET_WIDTH ** 2 + 4 * POCKET_WIDTH * POCKET_DEPTH
    assert on_floor.recess_coverage == pytest.approx(math.pi * 0.01 ** 2 / recess_area, abs=0.01)
    assert on_floor.open_coverage == 0.0


def test_a_convex_object_has_no_recess():
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=0.05)
    error = recess_error(sphere, sphere)
    assert error.recess_fraction == 0.0 and error.recess_rmse_mm is None and error.open_rmse_mm < 1e-3


def test_contacts_of_the_wrong_shape_are_refused(pocketed):
    truth, _ = pocketed
    with pytest.raises(ValueError, match=r"shape \(n, 3\)"):
        recess_error(truth, truth, contacts_m=np.zeros((4, 2)))


def test_the_hull_test_in_blocks_is_the_closed_form_cube_test():
    """Any block size gives the closed-form answer (a 327,680-face sphere's facets against 5,000
    samples at once asked for 12 GB)."""
    from scipy.spatial import ConvexHull

    from reconstruction.metrics import _inside_hull

    cube = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    equations = ConvexHull(cube.vertices).equations
    points = np.random.default_rng(0).uniform(-0.8, 0.8, (1001, 3))
    expected = np.all(np.abs(points) < 0.5, axis=1)
    assert 0.1 < expected.mean() < 0.5
    for budget in (1, 7, len(equations) * 1000, 10**9):
        np.testing.assert_array_equal(_inside_hull(points, equations, budget=budget), expected)
