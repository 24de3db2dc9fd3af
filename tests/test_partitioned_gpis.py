"""Partition-of-unity GPIS against independent answers: weights, one cell, gradients, a sphere."""

import numpy as np
import pytest

from reconstruction.gpis import GPIS
from reconstruction.kernels import ThinPlateKernel
from reconstruction.partitioned_gpis import PartitionedGPIS, wendland, wendland_derivative
from reconstruction.synthetic_contacts import sphere_contacts as exact_sphere_contacts

RADIUS = 0.05
BOUNDS = ((-0.08, -0.08, -0.08), (0.08, 0.08, 0.08))


def sphere_contacts(n, seed=0, radius=RADIUS):
    return exact_sphere_contacts(n, radius, seed)


@pytest.fixture(scope="module")
def sphere_pu():
    points, normals = sphere_contacts(150)
    return PartitionedGPIS(BOUNDS, max_cell_contacts=12).fit(points, normals)


def test_wendland_derivative_matches_finite_differences():
    t = np.linspace(0.01, 1.2, 57)
    h = 1e-6
    np.testing.assert_allclose(wendland_derivative(t), (wendland(t + h) - wendland(t - h)) / (2 * h), atol=1e-6)
    assert wendland(np.array([0.0]))[0] == 1.0 and wendland(np.array([1.0, 2.0])).max() == 0.0


def test_the_octree_adapts_to_density_and_the_weights_are_a_partition_of_unity(sphere_pu):
    pu = sphere_pu
    assert len(pu.cells) > 8
    contacts = pu.contact_points
    for cell in pu.cells:  # leaves hold at most max_cell_contacts, each contact is in one leaf
        inside = np.all(np.abs(contacts - cell.centre) <= cell.half, axis=1)
        assert inside.sum() <= pu.max_cell_contacts
    x = np.random.default_rng(1).uniform(-0.08, 0.08, (400, 3))
    total, per_cell = pu.weights(x)
    summed = np.full(len(x), pu.global_weight)
    for idx, w in per_cell:
        summed[idx] += w
    np.testing.assert_allclose(summed, total)
    normalised = pu.global_weight / total + sum(np.bincount(idx, w, len(x)) for idx, w in per_cell) / total
    np.testing.assert_allclose(normalised, 1.0)
    # every contact is covered by local fits: the global field has a negligible share there
    total_at_contacts, _ = pu.weights(contacts)
    assert np.max(pu.global_weight / total_at_contacts) < 0.01


def test_one_cell_is_the_local_gpis_fitted_on_all_contacts():
    points, normals = sphere_contacts(40, seed=2)
    pu = PartitionedGPIS(BOUNDS, max_cell_contacts=1000, global_weight=1e-9).fit(points, normals)
    assert len(pu.cells) == 1
    cell = pu.cells[0]
    radius = 1.5 * 2 * cell.fit_radius_m
    independent = GPIS(kernel=ThinPlateKernel(radius), bounds=BOUNDS).fit(points, normals)
    x = 0.06 * np.random.default_rng(3).uniform(-1, 1, (200, 3))
    np.testing.assert_allclose(pu.mean(x), independent.mean(x), atol=2e-6)
    np.testing.assert_allclose(pu.variance(x), independent.variance(x), rtol=1e-6, atol=1e-12)


def test_blended_gradient_matches_finite_differences(sphere_pu):
    x = 0.07 * np.random.default_rng(4).uniform(-1, 1, (60, 3))
    h = 2e-4
    fd = np.stack([(sphere_pu.mean(x + e).astype(float) - sphere_pu.mean(x - e)) / (2 * h)
                   for e in np.eye(3) * h], axis=1)
    grad = sphere_pu.gradient(x)
    # float32 means: the difference quotient carries ~1e-3 of rounding; the weights' derivative
    # terms are of order |f| / support ~ 0.1-1, so leaving them out would fail this
    np.testing.assert_allclose(grad, fd, atol=5e-3)


def test_sphere_zero_level_set_is_near_the_radius(sphere_pu):
    mesh = sphere_pu.mesh(resolution=40)
    radial = np.linalg.norm(mesh.vertices, axis=1) - RADIUS
    assert np.abs(radial).max() < 1.5e-3
    assert mesh.is_watertight


def test_incremental_add_and_tracker_match_direct_computation():
    points, normals = sphere_contacts(80, seed=5)
    # then 40 contacts in a cap of 8 deg around one direction: they crowd one leaf until it splits
    axis = np.array([0.3, 0.3, 1.0]) / np.linalg.norm([0.3, 0.3, 1.0])
    v = axis + np.tan(np.radians(8)) * np.random.default_rng(7).uniform(-0.7, 0.7, (40, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    points, normals = np.vstack([points, RADIUS * v]), np.vstack([normals, v])
    pu = PartitionedGPIS(BOUNDS, max_cell_contacts=8).fit(points[:80], normals[:80])
    candidates = 0.07 * np.random.default_rng(6).uniform(-1, 1, (300, 3))
    tracker = pu.variance_tracker(candidates)
    before = tracker.variance().copy()
    generation = pu.partition_generation
    for p, n in zip(points[80:], normals[80:]):
        pu.add(p, n)
    assert pu.n_contacts == 120
    assert pu.partition_generation > generation  # some leaf passed twice its capacity and split
    np.testing.assert_allclose(tracker.variance(), pu.variance(candidates), rtol=1e-8, atol=1e-14)
    assert np.mean(tracker.variance()) < np.mean(before)
    # every local fit holds exactly the contacts of its fit ball
    for cell in pu.cells:
        if cell.gp is not None:
            inside = np.linalg.norm(pu.contact_points - cell.centre, axis=1) <= cell.fit_radius_m
            assert cell.gp.n_contacts == inside.sum()
    np.testing.assert_allclose(pu.mean(points), 0.0, atol=1e-3)


def test_bad_settings_are_rejected():
    with pytest.raises(ValueError, match="bounds"):
        PartitionedGPIS(None)
    with pytest.raises(ValueError, match="indefinite"):
        PartitionedGPIS(BOUNDS, scale_factor=1.0)
    with pytest.raises(ValueError, match="local_kernel"):
        PartitionedGPIS(BOUNDS, local_kernel="nope")
    with pytest.raises(ValueError, match="normals"):
        PartitionedGPIS(BOUNDS, use_normals=False)
    with pytest.raises(RuntimeError, match="no contacts"):
        PartitionedGPIS(BOUNDS).mean(np.zeros((1, 3)))


def test_the_exploration_loop_and_the_variance_strategy_accept_it(tmp_path):
    from explorer.loop import ExplorationLoop, LoopConfig
    from explorer.recording import RunRecorder
    from explorer.strategies import ExplorationState, VarianceStrategy
    from fakes import FakePlanner, ScriptedStrategy, sphere_rig
    from test_loop_fast import scripted_touches

    _, rig = sphere_rig(0.04)
    gp = PartitionedGPIS(rig.prior.bounds())
    recorder = RunRecorder(tmp_path, dict(rig.description, seed=0, configuration={}))
    loop = ExplorationLoop(rig, FakePlanner(rig.positioner), ScriptedStrategy(scripted_touches()), gp,
                           LoopConfig(touches=6, proposal_rounds=1, max_realign_fraction=1.0,
                                      doubt_rim_margin_m=1.0, repress_force_n=0.0), recorder)
    records = loop.run()
    recorder.close()
    contacts = [r.position_m for r in records if r.kind == "contact"]  # realigns are set aside
    assert len(contacts) > 0
    np.testing.assert_allclose(gp.contact_points, contacts)

    # contacts on the upper half of a sphere only: the variance strategy goes to the lower half
    d = np.random.default_rng(8).normal(size=(200, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d = d[d[:, 2] > 0.2][:50]
    upper = PartitionedGPIS(rig.prior.bounds()).fit(0.04 * d, d)
    touches = VarianceStrategy().propose(ExplorationState(rig.prior, upper, touches=40), 2)
    assert all(t.target_m[2] < -0.01 for t in touches)
