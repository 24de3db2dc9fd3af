import numpy as np
import pytest

from explorer.strategies import (ExplorationState, RandomStrategy, UniformStrategy, VarianceStrategy,
                                 clear_approach, farthest_point_order, fibonacci_directions, make_strategy)
from explorer.touch import ObjectPrior, Touch, TouchOutcome
from reconstruction.gpis import GPIS

PRIOR = ObjectPrior(np.zeros(3), np.full(3, 0.05))


def test_fibonacci_directions_are_unit_and_evenly_spread():
    d = fibonacci_directions(200)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0)
    np.testing.assert_allclose(d.mean(0), 0, atol=0.01)
    nearest = np.sort(np.linalg.norm(d[:, None] - d[None], axis=-1), axis=1)[:, 1]
    assert nearest.max() / nearest.min() < 1.6


def test_farthest_point_order_spreads_the_first_touches():
    d = fibonacci_directions(100)
    order = farthest_point_order(d)
    first_six = d[order[:6]]
    gaps = np.linalg.norm(first_six[:, None] - first_six[None], axis=-1) + 3 * np.eye(6)
    assert gaps.min() > 1.0  # more than 60 deg apart


def test_uniform_touches_aim_at_the_prior_centre_from_its_box():
    strategy = UniformStrategy(directions=20)
    touches = strategy.propose(ExplorationState(PRIOR), 5)
    assert len(touches) == 5
    for t in touches:
        assert np.max(np.abs(t.target_m)) == pytest.approx(0.05)
        towards_centre = -t.target_m / np.linalg.norm(t.target_m)
        np.testing.assert_allclose(t.approach_dir, towards_centre, atol=1e-12)
    strategy.accepted(touches[0])
    assert not np.allclose(strategy.propose(ExplorationState(PRIOR), 1)[0].target_m, touches[0].target_m)


def test_random_strategy_is_reproducible_from_its_seed():
    a = RandomStrategy(3).propose(ExplorationState(PRIOR), 4)
    b = RandomStrategy(3).propose(ExplorationState(PRIOR), 4)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x.target_m, y.target_m)


def _sphere_gp(directions):
    gp = GPIS(bounds=PRIOR.bounds())
    gp.fit(0.04 * directions, directions)
    return gp


def test_variance_strategy_goes_to_the_unexplored_side_of_a_sphere():
    """Contacts only on the upper half: the most uncertain surface is the lower half; the target
    lies on the current 0-level set and the pad approaches along its inward normal there."""
    d = fibonacci_directions(60)
    gp = _sphere_gp(d[d[:, 2] > 0.2])
    state = ExplorationState(PRIOR, gp, touches=40)
    touches = VarianceStrategy().propose(state, 3)
    assert all(t.target_m[2] < -0.01 for t in touches)
    target = touches[0].target_m[None]
    assert abs(gp.mean(target)[0]) < 2e-3
    inward = gp.gradient(target)[0] / np.linalg.norm(gp.gradient(target)[0])
    assert np.dot(touches[0].approach_dir, inward) > 0.99
    assert touches[0].score >= touches[1].score >= touches[2].score
    for a in touches:  # 15 mm apart on the candidate grid, a little less after projection
        for b in touches:
            if a is not b:
                assert np.linalg.norm(a.target_m - b.target_m) >= 0.01


def test_variance_strategy_avoids_unreachable_targets():
    d = fibonacci_directions(60)
    gp = _sphere_gp(d[d[:, 2] > 0.2])
    first = VarianceStrategy().propose(ExplorationState(PRIOR, gp, touches=40), 1)[0]
    state = ExplorationState(PRIOR, gp, touches=40, unreachable_m=[first.target_m])
    second = VarianceStrategy().propose(state, 1)[0]
    assert np.linalg.norm(second.target_m - first.target_m) > 0.01



def test_variance_strategy_avoids_where_a_pad_went_through_to_a_farther_contact():
    d = fibonacci_directions(60)
    gp = _sphere_gp(d[d[:, 2] > 0.2])
    first = VarianceStrategy().propose(ExplorationState(PRIOR, gp, touches=40), 1)[0]
    probe = TouchOutcome(0, "contact", first.target_m, first.approach_dir,
                         position_m=first.target_m + 0.05 * first.approach_dir)
    passed = probe.passed_points(margin_m=0.009)
    state = ExplorationState(PRIOR, gp, touches=40, passed_m=list(passed))
    strategy = VarianceStrategy()
    second = strategy.propose(state, 1)[0]
    assert np.min(np.linalg.norm(passed - second.target_m, axis=1)) > strategy.passed_radius_m


def test_variance_strategy_looks_past_a_shortlist_it_has_ruled_out():
    """When every shortlisted candidate lies where a pad already went, the strategy checks the next
    ones instead of falling back to ``uniform``, and picks what one unlimited shortlist picks."""
    d = fibonacci_directions(60)
    gp = _sphere_gp(d[d[:, 2] > 0.2])
    whole = VarianceStrategy(shortlist=100_000)
    points, variance = whole.surface_variance(ExplorationState(PRIOR, gp, touches=40))
    passed = list(points[np.argsort(-variance)[:10]])           # the ten most uncertain: gone through
    state = ExplorationState(PRIOR, gp, touches=40, passed_m=passed)
    small = VarianceStrategy(shortlist=10)
    assert small._ranked_touches(*small.projected_candidates(state)[:3], state, 3) == []
    touches = small.propose(state, 3)
    expected = whole.propose(state, 3)
    assert [t.strategy for t in touches] == ["variance"] * 3
    for got, want in zip(touches, expected):
        np.testing.assert_allclose(got.target_m, want.target_m, atol=1e-12)
    assert min(np.min(np.linalg.norm(np.asarray(passed) - t.target_m, axis=1)) for t in touches) > small.passed_radius_m


def test_passed_points_run_from_the_target_to_a_margin_short_of_the_contact():
    target, along = np.array([0.01, 0.02, 0.03]), np.array([0.0, 1.0, 0.0])
    far = TouchOutcome(0, "contact", target, along, position_m=target + 0.05 * along)
    np.testing.assert_allclose(far.passed_points(0.009), target + np.arange(5)[:, None] * 0.01 * along, atol=1e-12)
    before = TouchOutcome(0, "contact", target, along, position_m=target - 0.002 * along)
    assert before.passed_points(0.009).shape == (0, 3)
    assert TouchOutcome(0, "miss", target, along).passed_points(0.009).shape == (0, 3)

def test_variance_strategy_starts_uniform():
    touches = VarianceStrategy().propose(ExplorationState(PRIOR), 2)
    assert all(t.strategy == "uniform" for t in touches)


def test_unknown_strategy_and_bad_touches():
    with pytest.raises(ValueError, match="unknown strategy"):
        make_strategy("greedy")
    with pytest.raises(ValueError, match="non-zero approach"):
        Touch(np.zeros(3), np.zeros(3))
    with pytest.raises(ValueError, match="positive"):
        ObjectPrior(np.zeros(3), np.array([0.1, 0.0, 0.1]))


def _open_box(outer=0.08, wall=0.01, height=0.06):
    """A cup: a box open at the top (+z), walls and floor ``wall`` thick, centred at the origin."""
    import trimesh
    body = trimesh.creation.box((outer, outer, height))
    cavity = trimesh.creation.box((outer - 2 * wall, outer - 2 * wall, height))
    cavity.apply_translation((0, 0, wall))
    return trimesh.boolean.difference([body, cavity], engine="manifold")


@pytest.fixture(scope="module")
def cup_and_gp():
    """The open box and a GPIS fitted to 400 sampled contacts on it."""
    from reconstruction.synthetic_contacts import sample_contacts
    cup = _open_box()
    points, normals, _, _ = sample_contacts(cup, 400, seed=3)
    return cup, GPIS(bounds=PRIOR.bounds()).fit(points, normals)


def test_clear_approach_enters_a_cup_through_its_opening(cup_and_gp):
    """A target in a cup, preferred from the side: that way in crosses the wall; the chosen one
    comes down through the opening and its path (centre and pad edges) misses the true cup."""
    cup, gp = cup_and_gp
    target = np.array([0.0, 0.0, 0.0])
    preferred = np.array([1.0, 0.0, 0.0])
    side_path = target[None] - np.linspace(0.007, 0.045, 20)[:, None] * preferred
    assert cup.contains(side_path).any()                         # the preferred way crosses the wall
    u = clear_approach(gp, target, preferred)
    assert np.linalg.norm(u) == pytest.approx(1.0)
    assert u[2] < -0.5                                           # comes down from above
    e1 = np.cross(u, [0.0, 1.0, 0.0]) if abs(u[1]) < 0.9 else np.cross(u, [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(u, e1)
    back = np.linspace(0.007, 0.045, 20)[:, None]
    for offset in (0.0 * e1, 0.009 * e1, -0.009 * e1, 0.009 * e2, -0.009 * e2):
        assert not cup.contains(target[None] - back * u + offset).any()


def test_clear_approach_keeps_a_free_preferred_direction():
    d = fibonacci_directions(80)
    gp = _sphere_gp(d)
    target = np.array([0.0, 0.0, 0.04])
    preferred = np.array([0.0, 0.0, -2.0])                       # straight down onto the top: free
    np.testing.assert_allclose(clear_approach(gp, target, preferred), [0.0, 0.0, -1.0])
    blocked = clear_approach(gp, np.array([0.0, 0.0, -0.04]), np.array([0.0, 0.0, -1.0]))
    assert blocked[2] > 0.2                                      # the bottom is reached from below


def test_variance_strategy_turns_only_unresolved_approaches_to_a_clear_way_in(cup_and_gp):
    state = ExplorationState(PRIOR, cup_and_gp[1], touches=40)
    targets = np.array([[0.0, 0.0, 0.0], [0.0, 0.03, 0.0]])
    sideways = np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    scores = np.array([2.0, 1.0])
    turned = VarianceStrategy()._ranked_touches(targets, sideways, scores, state, 2, np.array([False, True]))
    assert turned[0].approach_dir[2] < -0.5                      # unresolved: down through the opening
    np.testing.assert_allclose(turned[1].approach_dir, [1.0, 0.0, 0.0])   # resolved: as given
    kept = VarianceStrategy(clear_unresolved=False)._ranked_touches(targets, sideways, scores, state, 2,
                                                                    np.array([False, True]))
    np.testing.assert_allclose(kept[0].approach_dir, [1.0, 0.0, 0.0])
