import numpy as np
import pytest
import trimesh

from reconstruction.synthetic_contacts import ContactNoise, add_contact_noise, perturb_normals, sample_contacts


def test_noise_free_contacts_lie_on_the_surface_with_its_normals():
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=0.05)
    p, n, tp, tn = sample_contacts(sphere, 500, ContactNoise.off(), seed=1)
    np.testing.assert_allclose(p, tp)
    _, dist, _ = trimesh.proximity.closest_point(sphere, p)
    assert dist.max() < 1e-5  # trimesh's closest point is approximate at the micrometre level
    assert np.all(np.sum(n * p, axis=1) > 0)  # outward


def test_normal_error_has_the_requested_mean_angle():
    rng = np.random.default_rng(0)
    normals = rng.normal(size=(20000, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    tilted = perturb_normals(normals, 7.0, rng)
    angle = np.degrees(np.arccos(np.clip(np.sum(tilted * normals, 1), -1, 1)))
    assert angle.mean() == pytest.approx(7.0, rel=0.02)
    np.testing.assert_allclose(np.linalg.norm(tilted, axis=1), 1.0)


def test_position_noise_has_the_requested_spread_along_and_across_the_normal():
    box = trimesh.creation.box((0.1, 0.1, 0.1))
    noise = ContactNoise(normal_std_m=0.2e-3, tangent_std_m=1e-3)
    p, _, tp, tn = sample_contacts(box, 20000, noise, seed=2)
    along = np.sum((p - tp) * tn, axis=1)
    across = (p - tp) - along[:, None] * tn
    assert np.std(along) == pytest.approx(0.2e-3, rel=0.03)
    assert np.sqrt(np.mean(np.sum(across**2, axis=1)) / 2) == pytest.approx(1e-3, rel=0.03)


def test_area_uniform_sampling():
    box = trimesh.creation.box((0.2, 0.1, 0.1))  # the x faces are half the area of the others
    p, n, _, _ = sample_contacts(box, 30000, ContactNoise.off(), seed=3)
    x_faces = np.mean(np.abs(n[:, 0]) > 0.5)
    assert x_faces == pytest.approx(2 * 0.01 / (2 * 0.01 + 4 * 0.02), abs=0.01)


def test_bad_parameters():
    with pytest.raises(ValueError):
        ContactNoise(normal_std_m=-1)
    with pytest.raises(ValueError, match="at least one"):
        sample_contacts(trimesh.creation.box(), 0)


def test_a_pooled_draw_is_the_front_of_one_sequence_so_more_contacts_extend_fewer():
    box = trimesh.creation.box((0.1, 0.06, 0.04))
    few = sample_contacts(box, 50, seed=7, pool=400)
    more = sample_contacts(box, 300, seed=7, pool=400)
    for a, b in zip(few, more):
        np.testing.assert_array_equal(a, b[:50])
    whole = sample_contacts(box, 400, seed=7)  # the pool itself, drawn on its own
    np.testing.assert_array_equal(more[0], whole[0][:300])
    # without a pool a larger draw is another draw, not an extension of the smaller one
    assert not np.allclose(sample_contacts(box, 50, seed=7)[0], sample_contacts(box, 300, seed=7)[0][:50])
    with pytest.raises(ValueError, match="pool >= n"):
        sample_contacts(box, 500, seed=7, pool=400)


def test_noise_on_chosen_contacts_has_the_model_spread_about_their_own_normals():
    rng = np.random.default_rng(4)
    normal = np.array([1.0, 2.0, 2.0]) / 3.0  # a tilted plane: along / across mean its own axes
    tangent = np.cross(normal, [0.0, 0.0, 1.0])
    tangent /= np.linalg.norm(tangent)
    true_points = rng.uniform(-0.05, 0.05, (20000, 1)) * tangent
    true_normals = np.tile(normal, (20000, 1))
    exact = add_contact_noise(true_points, true_normals, ContactNoise.off(), rng)
    np.testing.assert_allclose(exact[0], true_points, atol=1e-15)
    np.testing.assert_allclose(exact[1], true_normals, atol=1e-12)
    points, normals = add_contact_noise(true_points, true_normals, ContactNoise(), rng)
    along = (points - true_points) @ normal
    across = (points - true_points) - along[:, None] * normal
    assert np.std(along) == pytest.approx(0.2e-3, rel=0.03)
    assert np.sqrt(np.mean(np.sum(across**2, axis=1)) / 2) == pytest.approx(1e-3, rel=0.03)
    angle = np.degrees(np.arccos(np.clip(normals @ normal, -1.0, 1.0)))
    assert np.mean(angle) == pytest.approx(7.0, rel=0.03)
