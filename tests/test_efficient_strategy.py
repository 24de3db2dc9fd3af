"""The ``efficient`` strategy: its information score against a brute-force recomputation, and its
time and penalty terms."""
import copy

import numpy as np
import pytest

from explorer.motion_time import MotionTimeEstimator, TouchTimeModel
from explorer.positioner import FixedStand, StandPose
from explorer.strategies import (EfficientStrategy, ExplorationState, VarianceStrategy,
                                 expected_variance_reduction, fibonacci_directions, normal_spread_rad)
from explorer.touch import ObjectPrior
from reconstruction.gpis import GPIS

PRIOR = ObjectPrior(np.zeros(3), np.full(3, 0.05))


def _upper_sphere_gp(use_normals=True, opposing=0.05):
    d = fibonacci_directions(60)
    d = d[d[:, 2] > 0.2]
    d[0] = [0.0, 0.0, 1.0]
    gp = GPIS(bounds=PRIOR.bounds(), use_normals=use_normals, opposing_normal_noise=opposing)
    return gp.fit(0.04 * d, d)


def _brute_force(gp, target, normal, surface):
    """Add the contact to a copy of the GPIS and integrate the variance drop over ``surface``."""
    after = copy.deepcopy(gp)
    after.add(target, normal if gp.use_normals else None)
    return float(np.sum(gp.variance(surface) - after.variance(surface)))


@pytest.mark.parametrize("use_normals", [True, False], ids=["normals", "no_normals"])
def test_variance_reduction_matches_adding_the_contact(use_normals):
    gp = _upper_sphere_gp(use_normals)
    rng = np.random.default_rng(4)
    surface = 0.04 * fibonacci_directions(300) + rng.normal(scale=1e-3, size=(300, 3))
    normals = fibonacci_directions(40)[[3, 20, 37]]          # upper (touched), middle, lower sphere
    targets = 0.04 * normals
    # an opposing pair within 15 mm: the new contact gets the tighter normal noise, as add() gives it
    top = np.array([[0.0, 0.0, 1.0]])
    targets = np.vstack([targets, gp.contact_points[:1] - 0.008 * top])
    normals = np.vstack([normals, -top])
    reduction, gradient_variance = expected_variance_reduction(gp, targets, normals, surface)
    expected = [_brute_force(gp, t, n, surface) for t, n in zip(targets, normals)]
    np.testing.assert_allclose(reduction, expected, rtol=1e-6, atol=1e-12 * max(expected))
    assert reduction[2] > reduction[0]   # the unexplored underside gains more than the touched top
    if use_normals:
        assert np.all(gradient_variance > 0) and gradient_variance[2] > gradient_variance[0]


def test_normal_spread_is_small_on_a_sphere_and_large_at_a_box_edge():
    d = fibonacci_directions(80)
    sphere = GPIS(bounds=PRIOR.bounds()).fit(0.04 * d, d)
    top = np.array([[0.0, 0.0, 0.04]])
    assert normal_spread_rad(sphere, top, np.array([[0.0, 0.0, -1.0]]), 0.009)[0] < np.radians(20)
    grid = np.linspace(-0.03, 0.03, 5)
    faces = []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            for a in grid:
                for b in grid:
                    p = np.zeros(3)
                    p[axis] = 0.03 * sign
                    p[[i for i in range(3) if i != axis]] = a, b
                    n = np.zeros(3)
                    n[axis] = sign
                    faces.append((p, n))
    box = GPIS(bounds=PRIOR.bounds()).fit(np.array([p for p, _ in faces]), np.array([n for _, n in faces]))
    edge = np.array([[0.03, 0.0, 0.03]])
    inward = -np.array([[1.0, 0.0, 1.0]]) / np.sqrt(2)
    face = np.array([[0.0, 0.0, 0.03]])
    assert (normal_spread_rad(box, edge, inward, 0.009)[0]
            > normal_spread_rad(box, face, np.array([[0.0, 0.0, -1.0]]), 0.009)[0] + np.radians(10))


def test_efficient_prefers_the_unexplored_side_and_ranks_by_score():
    gp = _upper_sphere_gp()
    strategy = EfficientStrategy()
    touches = strategy.propose(ExplorationState(PRIOR, gp, touches=40), 3)
    assert len(touches) == 3 and all(t.strategy == "efficient" for t in touches)
    assert all(t.target_m[2] < 0.0 for t in touches)
    assert touches[0].score >= touches[1].score >= touches[2].score
    assert touches[0].score == pytest.approx(strategy.last_scores["score"].max())


def test_efficient_avoids_the_neighbourhood_of_unreachable_targets():
    gp = _upper_sphere_gp()
    first = EfficientStrategy().propose(ExplorationState(PRIOR, gp, touches=40), 1)[0]
    state = ExplorationState(PRIOR, gp, touches=40, unreachable_m=[first.target_m])
    strategy = EfficientStrategy()
    second = strategy.propose(state, 1)[0]
    assert np.linalg.norm(second.target_m - first.target_m) > 0.01
    near = np.linalg.norm(strategy.last_scores["targets"] - first.target_m, axis=1) < 0.02
    assert np.all(strategy.last_scores["reach"][near] < 0.7)


def test_efficient_looks_past_a_shortlist_it_has_ruled_out():
    """Every shortlisted candidate lies where a pad already went: the next shortlist is scored,
    and its best candidate away from those points is proposed instead of a ``uniform`` touch."""
    gp = _upper_sphere_gp()
    strategy = EfficientStrategy(shortlist=10)
    points, variance = strategy.surface_variance(ExplorationState(PRIOR, gp, touches=40))
    passed = points[np.argsort(-variance)[:10]]
    state = ExplorationState(PRIOR, gp, touches=40, passed_m=list(passed))
    first = strategy.scored_candidates(state, 0)[0]
    assert np.all(np.min(np.linalg.norm(first[:, None] - passed[None], axis=-1), axis=1) < strategy.passed_radius_m)
    touches = strategy.propose(state, 2)
    assert [t.strategy for t in touches] == ["efficient"] * 2
    for start in range(10, len(points), 10):                   # the first shortlist with a candidate left
        targets, _, scores, _ = strategy.scored_candidates(state, start)
        away = np.min(np.linalg.norm(targets[:, None] - passed[None], axis=-1), axis=1) > strategy.passed_radius_m
        if away.any():
            break
    np.testing.assert_allclose(touches[0].target_m, targets[away][np.argmax(scores[away])], atol=1e-12)


class _TwoPosePlanner:
    """Pose 0 for approaches with a positive x component, pose 1 otherwise."""

    poses = (StandPose(0.0, 0.0), StandPose(np.pi / 2, 0.0))

    def pose_scores(self, approach):
        first = 0 if approach[0] > 0 else 1
        return [(1.0, self.poses[first]), (0.5, self.poses[1 - first])]


def test_motion_time_charges_stand_changes_and_travel():
    model = TouchTimeModel()
    estimator = MotionTimeEstimator(_TwoPosePlanner(), FixedStand(np.zeros(3)), model)
    targets = np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.0, 0.0]])
    approaches = np.array([[1.0, 0, 0], [1.0, 0, 0], [-1.0, 0, 0]])
    seconds = estimator.time_s(targets, approaches, np.zeros(3))
    assert seconds[0] == pytest.approx(model.press_s + model.transfer_s)
    assert seconds[1] == pytest.approx(seconds[0] + 0.1 * model.transfer_s_per_m)
    assert seconds[2] == pytest.approx(model.press_s + model.stand_change_s + model.stand_turn_s_per_rad * np.pi / 2)


def test_slow_candidates_lose_to_fast_ones_of_equal_information():
    """On a symmetric sphere half, doubling the time of one side moves the choice to the other."""
    gp = _upper_sphere_gp()

    class Slow:
        def time_s(self, targets, approaches, last):
            return np.where(targets[:, 0] > 0, 100.0, 4.0)

    touch = EfficientStrategy().propose(ExplorationState(PRIOR, gp, touches=40, motion=Slow()), 1)[0]
    assert touch.target_m[0] <= 0.0


def test_variance_is_unchanged_by_the_shared_candidate_code():
    gp = _upper_sphere_gp()
    touches = VarianceStrategy().propose(ExplorationState(PRIOR, gp, touches=40), 3)
    assert [t.strategy for t in touches] == ["variance"] * 3


def test_efficient_first_touches_each_face_of_the_prior_box_head_on():
    strategy = EfficientStrategy()
    seen = []
    for _ in range(6):
        touch = strategy.propose(ExplorationState(PRIOR, touches=len(seen)), 2)[0]
        assert touch.strategy == "efficient"
        outward = -touch.approach_dir
        assert np.isclose(np.abs(outward).max(), 1.0)                   # along a box axis
        np.testing.assert_allclose(touch.target_m, PRIOR.half_extent_m * outward, atol=1e-12)
        seen.append(tuple(np.round(outward)))
        strategy.accepted(touch)
    assert len(set(seen)) == 6
    assert strategy.propose(ExplorationState(PRIOR, touches=6), 1)[0].strategy == "uniform"


def test_planar_approach_follows_a_flat_patch_and_leaves_a_sphere_alone():
    from explorer.strategies import planar_approach

    rng = np.random.default_rng(0)
    xy = rng.uniform(-0.03, 0.03, size=(8, 2))
    plate = np.column_stack([xy, np.full(8, 0.005)])
    up = np.tile([0.0, 0.0, 1.0], (8, 1))
    target = np.array([[0.01, 0.0, 0.012]])                        # on a GPIS bulge 7 mm above the face
    oblique = np.array([[0.6, 0.0, -0.8]])                          # its GPIS normal, 37 deg off
    t, a, planar = planar_approach(plate, up, target, oblique, 0.05)
    assert planar[0]
    np.testing.assert_allclose(a[0], [0.0, 0.0, -1.0], atol=1e-12)
    np.testing.assert_allclose(t[0], [0.01, 0.0, 0.005], atol=1e-12)
    d = fibonacci_directions(200)
    d = d[d[:, 2] > 0.7]
    sphere_target = 0.04 * np.array([[0.3, 0.0, 0.954]])
    t, a, planar = planar_approach(0.04 * d, d, sphere_target, -sphere_target / 0.04, 0.05)
    assert not planar[0]
    np.testing.assert_array_equal(t, sphere_target)


def test_thin_axis_approach_turns_oblique_approaches_onto_a_plate_only():
    from explorer.strategies import thin_axis_approach

    approach = np.array([[0.8, 0.0, -0.6], [0.0, -0.9, 0.436], [1.0, 0.0, 0.0]])
    approach /= np.linalg.norm(approach, axis=1, keepdims=True)
    plate = ObjectPrior(np.zeros(3), np.array([0.1, 0.1, 0.01]))
    out = thin_axis_approach(plate, approach, np.ones(3, bool), 0.25, np.radians(75))
    np.testing.assert_allclose(out[:2], [[0, 0, -1.0], [0, 0, 1.0]])
    np.testing.assert_array_equal(out[2], approach[2])             # the rim: left as it was
    np.testing.assert_array_equal(thin_axis_approach(PRIOR, approach, np.ones(3, bool), 0.25, 1.3), approach)
