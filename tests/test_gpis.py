"""GPIS against closed forms (a sphere) and against itself (incremental vs refit, float32 vs float64)."""

import numpy as np
import pytest

from reconstruction.gpis import GPIS
from reconstruction.kernels import make_kernel
from reconstruction.synthetic_contacts import sphere_contacts as exact_sphere_contacts

RADIUS = 0.05
BOUNDS = ((-0.08, -0.08, -0.08), (0.08, 0.08, 0.08))


def sphere_contacts(n, seed=0, radius=RADIUS):
    return exact_sphere_contacts(n, radius, seed)


def random_directions(n, seed):
    v = np.random.default_rng(seed).normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


@pytest.fixture(scope="module")
def sphere_gp():
    points, normals = sphere_contacts(100)
    return GPIS(noise=1e-4, normal_noise=0.01, bounds=BOUNDS).fit(points, normals)


def test_mean_is_zero_and_gradient_inward_at_contacts(sphere_gp):
    points, normals = sphere_contacts(100)
    assert np.abs(sphere_gp.mean(points)).max() < 5e-5
    grad = sphere_gp.gradient(points)
    cos = np.sum(grad * -normals, axis=1) / np.linalg.norm(grad, axis=1)
    assert np.degrees(np.arccos(np.clip(cos, -1, 1))).max() < 1.5


def test_sign_convention_positive_inside_negative_outside(sphere_gp):
    d = random_directions(200, 3)
    assert np.all(sphere_gp.mean(0.5 * RADIUS * d) > 0)
    assert np.all(sphere_gp.mean(1.4 * RADIUS * d) < 0)


def test_gradient_matches_finite_differences_of_the_mean(sphere_gp):
    x = 0.07 * np.random.default_rng(4).uniform(-1, 1, (20, 3))
    h = 1e-4
    fd = np.stack([(sphere_gp.mean(x + e) - sphere_gp.mean(x - e)) / (2 * h)
                   for e in np.eye(3) * h], axis=1)
    np.testing.assert_allclose(sphere_gp.gradient(x), fd, atol=2e-3)


def test_float32_mean_matches_float64_posterior(sphere_gp):
    x = 0.07 * np.random.default_rng(5).uniform(-1, 1, (300, 3))
    gp = sphere_gp
    alpha = gp._factor.solve_upper(gp._factor.solve_lower(gp._y))
    exact = gp.cross_covariance(x).T @ alpha
    assert np.abs(gp.mean(x) - exact).max() < 2e-6


def test_sphere_mesh_matches_closed_form(sphere_gp):
    mesh = sphere_gp.mesh(resolution=64)
    assert mesh.is_watertight
    radial_error = np.linalg.norm(mesh.vertices, axis=1) - RADIUS
    assert np.sqrt(np.mean(radial_error**2)) < 2e-4
    assert mesh.volume == pytest.approx(4 / 3 * np.pi * RADIUS**3, rel=0.02)
    outward = np.sum(mesh.face_normals * mesh.triangles_center, axis=1) > 0
    assert outward.mean() > 0.999


def test_mesh_vertices_lie_on_the_zero_level(sphere_gp):
    mesh = sphere_gp.mesh(resolution=96)
    assert np.abs(sphere_gp.mean(mesh.vertices)).max() < 1e-4


def test_classic_gpis_without_normals_finds_the_sphere():
    points, _ = sphere_contacts(100)
    gp = GPIS(use_normals=False, noise=1e-3, bounds=BOUNDS).fit(points)
    assert gp.n_rows == 100 + 15
    mesh = gp.mesh(resolution=48)
    err = np.linalg.norm(mesh.vertices, axis=1) - RADIUS
    assert np.sqrt(np.mean(err**2)) < 3e-3
    assert gp.mean(np.zeros((1, 3)))[0] > 0


def test_variance_is_non_negative_and_shrinks_near_observations(sphere_gp):
    rng = np.random.default_rng(6)
    x = rng.uniform(-0.08, 0.08, (2000, 3))
    var = sphere_gp.variance(x)
    assert var.min() >= -1e-12
    points, _ = sphere_contacts(100)
    at_contacts = sphere_gp.variance(points)
    far = sphere_gp.variance(np.array([[0.08, 0.08, 0.08]]))
    assert at_contacts.max() < 1e-3 * far[0]
    assert at_contacts.max() < var.max()


def test_adding_a_contact_lowers_the_variance_there():
    points, normals = sphere_contacts(30)
    gp = GPIS(bounds=BOUNDS).fit(points, normals)
    new = np.array([[0.0, 0.0, RADIUS]])
    before = gp.variance(new)[0]
    gp.add(new[0], np.array([0.0, 0.0, 1.0]))
    after = gp.variance(new)[0]
    assert after < 0.1 * before
    assert after < 2 * gp.noise**2


@pytest.mark.parametrize("use_normals", [True, False])
def test_incremental_add_equals_refit(use_normals):
    points, normals = sphere_contacts(40, seed=2)
    ref = GPIS(use_normals=use_normals, bounds=BOUNDS).fit(points, normals)
    inc = GPIS(use_normals=use_normals, bounds=BOUNDS).fit(points[:25], normals[:25])
    for p, n in zip(points[25:], normals[25:]):
        inc.add(p, n if use_normals else None)
    x = 0.07 * np.random.default_rng(7).uniform(-1, 1, (200, 3))
    np.testing.assert_allclose(inc.mean(x), ref.mean(x), atol=2e-6)
    np.testing.assert_allclose(inc.gradient(x), ref.gradient(x), atol=2e-5)
    np.testing.assert_allclose(inc.variance(x), ref.variance(x), atol=1e-10)


def test_variance_tracker_matches_full_recomputation():
    points, normals = sphere_contacts(60, seed=3)
    gp = GPIS(bounds=BOUNDS).fit(points[:20], normals[:20])
    candidates = 0.06 * random_directions(500, 8)
    tracker = gp.variance_tracker(candidates)
    tracker.variance()
    for p, n in zip(points[20:], normals[20:]):
        gp.add(p, n)
        got = tracker.variance()
    np.testing.assert_allclose(got, gp.variance(candidates), rtol=1e-6, atol=1e-12)
    gp.fit(points[:10], normals[:10])  # a refit must be noticed
    np.testing.assert_allclose(tracker.variance(), gp.variance(candidates), rtol=1e-6, atol=1e-12)


def test_reference_kernel_is_solved_and_fits_the_sphere():
    points, normals = sphere_contacts(80)
    gp = GPIS(kernel="thin_plate_reference", bounds=BOUNDS).fit(points, normals)
    assert np.abs(gp.mean(points)).max() < 1e-3
    mesh = gp.mesh(resolution=48)
    err = np.linalg.norm(mesh.vertices, axis=1) - RADIUS
    assert np.sqrt(np.mean(err**2)) < 2e-3
    gp.add(np.array([RADIUS, 0, 0]), np.array([1.0, 0, 0]))
    assert gp.n_contacts == 81


def test_squared_exponential_kernel_fits_the_sphere():
    points, normals = sphere_contacts(150)
    gp = GPIS(kernel="squared_exponential", bounds=BOUNDS).fit(points, normals)
    assert np.abs(gp.mean(points)).max() < 1e-3


def test_without_bounds_the_radius_grows_with_a_warning():
    points, normals = sphere_contacts(20)
    gp = GPIS().fit(points * 0.5, normals)
    radius = gp.kernel.radius_m
    with pytest.warns(RuntimeWarning, match="refitting"):
        gp.add(np.array([0.3, 0.0, 0.0]), np.array([1.0, 0, 0]))
    assert gp.kernel.radius_m > radius
    assert gp.n_contacts == 21


# --------------------------------------------------------------------- bad input
def test_empty_input_is_rejected():
    with pytest.raises(ValueError, match="no contact points"):
        GPIS().fit(np.zeros((0, 3)), np.zeros((0, 3)))


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_points_are_rejected(bad):
    points, normals = sphere_contacts(5)
    points[2, 1] = bad
    with pytest.raises(ValueError, match="NaN or inf"):
        GPIS().fit(points, normals)


def test_zero_normals_are_rejected_and_others_normalised():
    points, normals = sphere_contacts(10)
    bad = normals.copy()
    bad[3] = 0
    with pytest.raises(ValueError, match=r"normals \[3\] are zero"):
        GPIS().fit(points, bad)
    scaled = GPIS(bounds=BOUNDS).fit(points, normals * 3.0)
    unit = GPIS(bounds=BOUNDS).fit(points, normals)
    x = np.zeros((1, 3))
    np.testing.assert_allclose(scaled.mean(x), unit.mean(x), rtol=1e-6)


@pytest.mark.parametrize("points_shape, normals_shape", [((5, 2), (5, 3)), ((5, 3), (4, 3)),
                                                         ((3,), (3,))])
def test_mismatched_shapes_are_rejected(points_shape, normals_shape):
    with pytest.raises(ValueError, match="shape"):
        GPIS().fit(np.ones(points_shape), np.ones(normals_shape))


def test_missing_normals_are_rejected():
    with pytest.raises(ValueError, match="needs normals"):
        GPIS().fit(np.ones((4, 3)))


def test_duplicate_contacts_are_repeated_measurements():
    """Documented handling: duplicates are kept; the noise term keeps the system well posed and
    the surface equals the one from the unique contacts up to the halved noise."""
    points, normals = sphere_contacts(50)
    dup = GPIS(bounds=BOUNDS).fit(np.vstack([points, points[:10]]), np.vstack([normals, normals[:10]]))
    single = GPIS(bounds=BOUNDS).fit(points, normals)
    x = 0.06 * random_directions(100, 9)
    np.testing.assert_allclose(dup.mean(x), single.mean(x), atol=1e-4)


def test_one_contact_gives_a_plane_through_it():
    gp = GPIS(bounds=BOUNDS).fit(np.array([[0.0, 0.0, 0.02]]), np.array([[0.0, 0.0, 1.0]]))
    assert abs(gp.mean(np.array([[0.0, 0.0, 0.02]]))[0]) < 1e-4
    assert gp.mean(np.array([[0.0, 0.0, 0.0]]))[0] > 0
    assert gp.mean(np.array([[0.0, 0.0, 0.04]]))[0] < 0


def test_contacts_outside_the_bounds_are_rejected():
    with pytest.raises(ValueError, match="outside the GPIS bounds"):
        GPIS(bounds=BOUNDS).fit(np.array([[0.1, 0, 0]]), np.array([[1.0, 0, 0]]))


def test_queries_before_fit_and_bad_parameters():
    with pytest.raises(RuntimeError, match="no observations"):
        GPIS().mean(np.zeros((1, 3)))
    with pytest.raises(ValueError, match="unknown kernel"):
        GPIS(kernel="gaussian")
    with pytest.raises(ValueError, match="noise"):
        GPIS(noise=0.0)
    with pytest.raises(ValueError, match="bounds"):
        GPIS(bounds=((0, 0, 0), (0, 1, 1)))


def test_mesh_without_a_surface_in_the_bounds_is_an_error():
    gp = GPIS(bounds=BOUNDS).fit(np.array([[0.0, 0.0, 0.02]]), np.array([[0.0, 0.0, 1.0]]))
    with pytest.raises(ValueError, match="no 0-level set"):
        gp.mesh(bounds=((-0.01, -0.01, -0.01), (0.01, 0.01, 0.01)), resolution=16)


def test_quadratic_trend_keeps_sparse_reconstructions_closed():
    """With 12 contacts the plain thin-plate mean fades towards 0 between contacts; the trend gives
    the posterior a closed shape to fall back on, so the mesh is one sphere-like surface."""
    points, normals = sphere_contacts(12, seed=4)
    with_trend = GPIS(bounds=BOUNDS).fit(points, normals).mesh(resolution=48)
    without = GPIS(bounds=BOUNDS, trend=None).fit(points, normals).mesh(resolution=48)

    def rmse(mesh):
        return np.sqrt(np.mean((np.linalg.norm(mesh.vertices, axis=1) - RADIUS) ** 2))

    assert rmse(with_trend) < 0.5 * rmse(without)
    assert len(with_trend.split(only_watertight=False)) == 1


def test_quadratic_trend_covariance_is_consistent_with_its_features():
    from reconstruction.kernels import QuadraticTrend

    trend = QuadraticTrend(np.array([0.01, 0.0, -0.02]), 2.0)
    x = np.random.default_rng(0).uniform(-0.05, 0.05, (5, 3))
    h = 1e-6
    feats = trend.features(x)
    fd = np.stack([(trend.features(x + e)[:, 0] - trend.features(x - e)[:, 0]) / (2 * h)
                   for e in np.eye(3) * h], axis=1)
    np.testing.assert_allclose(feats[:, 1:], fd, atol=1e-8)
    cov = trend.joint_covariance(x, x)
    np.testing.assert_allclose(cov[:, 0, :, 0], 4.0 * np.outer(feats[:, 0], feats[:, 0]))
    np.testing.assert_allclose(np.diagonal(cov[:, 0, :, 0]), trend.variance(x))


def _free_space_points(n, seed):
    """(n, 3) points outside the 5 cm sphere, inside BOUNDS, with f = -(distance to the sphere)."""
    v = random_directions(n, seed)
    radii = np.random.default_rng(seed + 1).uniform(0.055, 0.075, n)
    return v * radii[:, None], RADIUS - radii


def test_add_values_accepts_a_block_larger_than_the_spare_capacity():
    """Issue 10: 1,000 values at once after 200 contacts with normals (800 rows, tail of 512)."""
    points, normals = sphere_contacts(200, seed=5)
    free, values = _free_space_points(1000, seed=6)
    gp = GPIS(bounds=BOUNDS).fit(points, normals)
    candidates = 0.07 * random_directions(300, 9)
    tracker = gp.variance_tracker(candidates)
    tracker.variance()
    gp.add_values(free, values, noise=2e-3)
    chunked = GPIS(bounds=BOUNDS).fit(points, normals)
    for s in range(0, 1000, 100):
        chunked.add_values(free[s:s + 100], values[s:s + 100], noise=2e-3)
    refit = GPIS(bounds=BOUNDS).fit(points, normals).add_values(free[:1], values[:1], noise=2e-3)
    refit.add_values(free[1:], values[1:], noise=2e-3)
    refit._factor_all()  # one dense factorisation of all rows: the refit answer
    x = 0.07 * np.random.default_rng(7).uniform(-1, 1, (300, 3))
    for other in (chunked, refit):
        np.testing.assert_allclose(gp.mean(x), other.mean(x), atol=2e-6)
        np.testing.assert_allclose(gp.variance(x), other.variance(x), rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(tracker.variance(), refit.variance(candidates), rtol=1e-6, atol=1e-12)


@pytest.mark.parametrize("failure", ["factor", "bookkeeping"])
def test_a_failed_add_values_leaves_the_gpis_unchanged(failure, monkeypatch):
    import reconstruction.cholesky as cholesky

    points, normals = sphere_contacts(60, seed=5)
    free, values = _free_space_points(700, seed=6)
    gp = GPIS(bounds=BOUNDS, noise=1e-3).fit(points, normals)
    gp.add_values(free[:50], values[:50])  # rows in the factor's tail, so a rollback must cut it
    x = 0.07 * np.random.default_rng(7).uniform(-1, 1, (100, 3))
    mean, variance, rows = gp.mean(x), gp.variance(x), gp.n_rows
    with monkeypatch.context() as patch:
        if failure == "factor":
            def not_pd(matrix):
                raise cholesky.NotPositiveDefiniteError("injected")
            patch.setattr(cholesky, "_cholesky", not_pd)
            error = cholesky.NotPositiveDefiniteError
        else:  # the factor grew, then the bookkeeping after it failed
            def broken(*args, **kwargs):
                raise MemoryError("injected")
            patch.setattr(gp, "_stage", broken)
            error = MemoryError
        with pytest.raises(error):
            gp.add_values(free[50:], values[50:])
    assert gp.n_rows == rows
    np.testing.assert_array_equal(gp.mean(x), mean)
    np.testing.assert_allclose(gp.variance(x), variance, rtol=1e-12, atol=1e-15)
    gp.add_values(free[50:], values[50:])  # still usable, and equal to a clean build
    clean = GPIS(bounds=BOUNDS, noise=1e-3).fit(points, normals)
    clean.add_values(free[:50], values[:50]).add_values(free[50:], values[50:])
    np.testing.assert_allclose(gp.mean(x), clean.mean(x), atol=2e-6)


def test_the_kernel_declares_how_the_system_is_solved():
    """A kernel instance declaring itself indefinite is solved by LU (refit per add) and has no
    variance tracker; the answers equal the Cholesky path's for the same (in fact definite) kernel."""
    from reconstruction.kernels import ThinPlateKernel

    class DeclaredIndefinite(ThinPlateKernel):
        positive_definite = False

    points, normals = sphere_contacts(40, seed=2)
    radius = float(np.linalg.norm(np.subtract(*BOUNDS)))
    lu = GPIS(kernel=DeclaredIndefinite(radius), bounds=BOUNDS).fit(points[:30], normals[:30])
    chol = GPIS(kernel=ThinPlateKernel(radius), bounds=BOUNDS).fit(points[:30], normals[:30])
    for p, n in zip(points[30:], normals[30:]):
        lu.add(p, n)
        chol.add(p, n)
    assert not lu.positive_definite and chol.positive_definite
    x = 0.07 * np.random.default_rng(7).uniform(-1, 1, (100, 3))
    np.testing.assert_allclose(lu.mean(x), chol.mean(x), atol=2e-6)
    np.testing.assert_allclose(lu.variance(x), chol.variance(x), rtol=1e-6, atol=1e-12)
    with pytest.raises(ValueError, match="positive definite"):
        lu.variance_tracker(x)
    with pytest.raises(RuntimeError, match="not positive definite"):
        lu.whiten(np.zeros(lu.n_rows))


def test_factor_surface_for_trackers_is_consistent():
    """whiten / factor_rows / cross_covariance(start, stop) against a dense factorisation."""
    points, normals = sphere_contacts(30, seed=4)
    gp = GPIS(bounds=BOUNDS).fit(points[:20], normals[:20])
    generation = gp.generation
    gp.add(points[20:], normals[20:])
    assert gp.generation == generation  # an incremental add is not a refit
    x = 0.07 * random_directions(50, 3)
    k = gp.cross_covariance(x)
    np.testing.assert_allclose(gp.cross_covariance(x, 8, 90), k[8:90])
    L = gp.factor_rows(0, gp.n_rows)
    np.testing.assert_allclose(L @ gp.whiten(k), k, atol=1e-10 * np.abs(k).max())
    np.testing.assert_allclose(gp.factor_rows(40, 100), L[40:100, :100])
    prior = gp.prior_variance(x) - np.einsum("ij,ij->j", gp.whiten(k), gp.whiten(k))
    np.testing.assert_allclose(prior, gp.variance(x), rtol=1e-9, atol=1e-15)
    gp.fit(points, normals)
    assert gp.generation == generation + 1


def _thin_slab_contacts(n, thickness=0.004, seed=0):
    """Contacts on both faces of a 6 x 6 cm slab ``thickness`` thick: normals +z on top, -z below."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-0.03, 0.03, (n, 2))
    top = rng.random(n) < 0.5
    z = np.where(top, thickness / 2, -thickness / 2)
    normals = np.zeros((n, 3))
    normals[:, 2] = np.where(top, 1.0, -1.0)
    return np.column_stack([xy, z]), normals


def test_opposing_normal_noise_applies_to_thin_walls_only():
    gp = GPIS(bounds=BOUNDS, opposing_normal_noise=0.05)
    slab_points, slab_normals = _thin_slab_contacts(60)
    noise, gain = gp._normal_noise_per_contact(slab_points, slab_normals)
    # every contact with an opposite-face contact within 15 mm is tightened, the rest are not
    opposite = [np.any((np.linalg.norm(slab_points - p, axis=1) <= 0.015) & (slab_normals[:, 2] == -n[2]))
                for p, n in zip(slab_points, slab_normals)]
    np.testing.assert_array_equal(noise == 0.05, opposite)
    assert np.mean(opposite) > 0.8
    sphere_points, sphere_normals = sphere_contacts(100)  # 5 cm sphere: no opposing neighbour
    assert np.all(gp._normal_noise_per_contact(sphere_points, sphere_normals)[0] == gp.normal_noise)
    x = 0.07 * np.random.default_rng(7).uniform(-1, 1, (100, 3))
    plain = GPIS(bounds=BOUNDS).fit(sphere_points, sphere_normals)
    np.testing.assert_array_equal(gp.fit(sphere_points, sphere_normals).mean(x), plain.mean(x))


def test_opposing_normal_noise_sees_contacts_already_added():
    points, normals = _thin_slab_contacts(2, seed=3)
    points[1] = points[0] + [0.005, 0.0, 0.0]
    points[:, 2] = [0.002, -0.002]
    normals[:, 2] = [1.0, -1.0]
    gp = GPIS(bounds=BOUNDS, opposing_normal_noise=0.05).fit(points[:1], normals[:1])
    assert gp._normal_noise_per_contact(points[1:], normals[1:])[0][0] == 0.05
    with pytest.raises(ValueError, match="opposing_normal_noise"):
        GPIS(opposing_normal_noise=0.0)


def test_reassessing_contact_noise_after_adds_gives_the_field_of_one_fit():
    """Added one by one, a slab's contacts are judged only against those before them, so some faces
    touched first stay loose; :meth:`GPIS.reassess_contact_noise` must then give the field a single
    fit of the same contacts gives (which judges every contact against all), with the value rows
    added since kept, for any gradient gain."""
    points, normals = _thin_slab_contacts(30, seed=5)
    free = np.array([[0.0, 0.0, 0.02], [0.01, -0.01, -0.02]])
    x = 0.05 * np.random.default_rng(11).uniform(-1, 1, (300, 3))
    for gain in (1.0, 3.0):
        added = GPIS(bounds=BOUNDS, opposing_gradient_gain=gain)
        for p, n in zip(points, normals):
            added.add(p, n)
        added.add_values(free, [-0.01, -0.01])
        once = GPIS(bounds=BOUNDS, opposing_gradient_gain=gain).fit(points, normals).add_values(free, [-0.01, -0.01])
        assert np.max(np.abs(added.mean(x) - once.mean(x))) > 1e-5   # the loose first faces show
        # the mean is evaluated in float32 (reconstruction/gpis.py): equal weights give means equal
        # to its rounding, which the summation order sets differently on other CPUs (6e-8 of 0.1 m
        # on one machine, 0 on another); the loose faces above differ by 1e-2
        float32_rounding = 64 * np.finfo(np.float32).eps * np.abs(once.mean(x)).max()
        np.testing.assert_allclose(added.reassess_contact_noise().mean(x), once.mean(x), rtol=0, atol=float32_rounding)


def test_a_failed_reassessment_leaves_the_gpis_as_it_was(monkeypatch):
    points, normals = _thin_slab_contacts(20, seed=5)
    gp = GPIS(bounds=BOUNDS, opposing_gradient_gain=3.0)
    for p, n in zip(points, normals):
        gp.add(p, n)
    x = 0.05 * np.random.default_rng(2).uniform(-1, 1, (50, 3))
    before, y, generation = gp.mean(x), gp._y.copy(), gp.generation

    def half_done(self):
        self._generation += 1
        self._alpha = None
        raise np.linalg.LinAlgError("not positive definite")

    monkeypatch.setattr(GPIS, "_factor_all", half_done)
    with pytest.raises(np.linalg.LinAlgError):
        gp.reassess_contact_noise()
    monkeypatch.undo()
    assert gp.generation == generation
    np.testing.assert_array_equal(gp._y, y)
    np.testing.assert_array_equal(gp.mean(x), before)


def test_the_gradient_gain_makes_the_field_rise_that_much_faster_into_a_thin_wall_only():
    """With ``opposing_gradient_gain`` g the fitted gradient at a thin wall's tightened contacts is
    close to -g n (their rows ask for it at noise 0.05 g; the kernel's smoothness holds it a little
    below), while a sphere (no opposing pair) is fitted
    exactly as without the gain."""
    points, normals = _thin_slab_contacts(60, seed=2)
    gp = GPIS(bounds=BOUNDS, opposing_gradient_gain=3.0).fit(points, normals)
    noise, gain = gp._normal_noise_per_contact(points, normals)
    tight = gain == 3.0
    assert tight.mean() > 0.8 and np.all(noise[tight] == gp.opposing_normal_noise) and np.all(gain[~tight] == 1.0)
    np.testing.assert_array_equal(gp.thin_wall_contacts(), tight)
    slope = -np.einsum("ij,ij->i", gp.gradient(points[tight]), normals[tight])
    plain_slope = -np.einsum("ij,ij->i", GPIS(bounds=BOUNDS).fit(points, normals).gradient(points[tight]), normals[tight])
    # The smooth kernel resists a steep thin wall either way; the gain scales what it is asked for.
    assert np.all((slope > 2.0) & (slope <= 3.0 + 3 * 3 * gp.opposing_normal_noise)), slope
    assert np.all((plain_slope > 0.7) & (plain_slope <= 1.0 + 3 * gp.opposing_normal_noise)), plain_slope
    assert 2.0 < np.median(slope / plain_slope) < 3.5
    sphere_points, sphere_normals = sphere_contacts(80)
    q = 0.07 * np.random.default_rng(7).uniform(-1, 1, (100, 3))
    sphere = GPIS(bounds=BOUNDS, opposing_gradient_gain=3.0).fit(sphere_points, sphere_normals)
    assert not sphere.thin_wall_contacts().any()
    np.testing.assert_array_equal(sphere.mean(q), GPIS(bounds=BOUNDS).fit(sphere_points, sphere_normals).mean(q))
    assert GPIS(opposing_gradient_gain=2.0).unfitted_copy().opposing_gradient_gain == 2.0
    with pytest.raises(ValueError, match="opposing_gradient_gain"):
        GPIS(opposing_gradient_gain=0.0)


def test_a_doubtful_contact_on_a_thin_wall_is_tightened_only_when_the_opposing_rule_overrides_its_floor():
    """Two contacts 5 mm apart on the two faces of a 4 mm slab, the second doubtful (normal-noise
    floor 0.5). By default the floor wins; with ``opposing_overrides_floor`` the doubtful contact
    gets ``opposing_normal_noise`` like an undoubted one: the same field as without the floor. A
    doubtful contact with no opposing neighbour keeps its floor either way."""
    points = np.array([[0.0, 0.0, 0.002], [0.005, 0.0, -0.002]])
    normals = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])
    x = 0.05 * np.random.default_rng(3).uniform(-1, 1, (200, 3))

    def field(overrides, floor):
        gp = GPIS(bounds=BOUNDS, opposing_normal_noise=0.05, opposing_overrides_floor=overrides)
        gp.add(points[0], normals[0])
        gp.add(points[1], normals[1], normal_noise=floor)
        return gp

    undoubted = field(False, None).mean(x)
    np.testing.assert_allclose(field(True, 0.5).mean(x), undoubted, rtol=0, atol=1e-9)
    assert np.max(np.abs(field(False, 0.5).mean(x) - undoubted)) > 1e-4
    assert field(True, 0.5).unfitted_copy().opposing_overrides_floor

    lone = GPIS(bounds=BOUNDS, opposing_overrides_floor=True)
    lone.add(points[0], normals[0], normal_noise=0.5)
    floored = GPIS(bounds=BOUNDS)
    floored.add(points[0], normals[0], normal_noise=0.5)
    np.testing.assert_allclose(lone.mean(x), floored.mean(x), rtol=0, atol=1e-12)


@pytest.mark.parametrize("kernel", ["thin_plate", "thin_plate_reference"])  # Cholesky and LU
def test_leave_one_out_is_a_refit_without_the_contact(kernel):
    # Against the independent answer: a GPIS fitted to the other contacts (and the same free-space
    # rows), queried at the contact left out. An ellipsoid, so no contact has an opposing
    # neighbour whose noise would change without it. One kernel object for both, since a named
    # kernel's radius follows the contacts' spread.
    points, normals = sphere_contacts(24, seed=3)
    points, normals = points * [1.0, 0.8, 0.6], normals / [1.0, 0.8, 0.6]
    free = np.array([[0.07, 0.0, 0.0], [0.0, 0.07, 0.02]])
    kernel = make_kernel(kernel, float(np.linalg.norm(np.subtract(BOUNDS[1], BOUNDS[0]))), 0.1)
    gp = GPIS(kernel=kernel, bounds=BOUNDS).fit(points, normals).add_values(free, np.array([-0.02, -0.03]))
    mean, std = gp.leave_one_out()
    assert mean.shape == std.shape == (24,)
    for i in (0, 11, 23):
        others = np.arange(24) != i
        refit = GPIS(kernel=kernel, bounds=BOUNDS).fit(points[others], normals[others])
        refit.add_values(free, np.array([-0.02, -0.03]))
        refit._weights_table()  # the posterior weights in float64 (``mean`` is float32)
        exact = float(refit.cross_covariance(points[i:i + 1])[:, 0] @ refit._alpha)
        assert mean[i] == pytest.approx(exact, rel=1e-6, abs=1e-12)
        assert std[i] == pytest.approx(np.sqrt(refit.variance(points[i:i + 1])[0]), rel=1e-6)
    assert np.abs(mean).max() > 1e-5  # left out, a contact is no longer pinned to f = 0


@pytest.mark.parametrize("kernel", ["thin_plate", "thin_plate_reference"])  # Cholesky and LU
def test_leave_one_out_normals_are_a_refit_without_the_contact(kernel):
    # The field's outward normal (-grad f, unit) of a GPIS fitted without the contact, at the
    # contact: the same ellipsoid as above, so the answer is not the contact's own normal.
    points, normals = sphere_contacts(24, seed=3)
    points, normals = points * [1.0, 0.8, 0.6], normals / [1.0, 0.8, 0.6]
    normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    kernel = make_kernel(kernel, float(np.linalg.norm(np.subtract(BOUNDS[1], BOUNDS[0]))), 0.1)
    gp = GPIS(kernel=kernel, bounds=BOUNDS).fit(points, normals)
    mean, std, left_out = gp.leave_one_out_with_normals()
    np.testing.assert_array_equal(np.column_stack([mean, std]), np.column_stack(gp.leave_one_out()))
    assert left_out.shape == (24, 3)
    np.testing.assert_allclose(np.linalg.norm(left_out, axis=1), 1.0, rtol=1e-9)
    for i in (0, 11, 23):
        others = np.arange(24) != i
        refit = GPIS(kernel=kernel, bounds=BOUNDS).fit(points[others], normals[others])
        exact = -refit.gradient(points[i:i + 1])[0]
        exact /= np.linalg.norm(exact)
        np.testing.assert_allclose(left_out[i], exact, atol=2e-4)  # the refit's gradient is float32
    assert np.max(np.abs(left_out - normals)) > 1e-4  # not the contacts' own normals


def test_leave_one_out_needs_normals():
    points, _ = sphere_contacts(20)
    with pytest.raises(ValueError, match="normals"):
        GPIS(use_normals=False, bounds=BOUNDS).fit(points).leave_one_out()


def test_mesh_vertices_lie_on_the_mean_zero_unless_asked_for_the_linear_ones(monkeypatch):
    # The mesh moves each vertex along its grid edge to the mean's zero (here every vertex, however
    # little); refine_steps=0 keeps marching cubes' linear interpolation, whose vertices sit off it.
    from reconstruction import meshing

    monkeypatch.setattr(meshing, "MIN_REFINE_MOVE", 0.0)
    points, normals = exact_sphere_contacts(60, radius_m=0.04, seed=1)
    gp = GPIS().fit(points, normals)
    refined = gp.mesh(resolution=24)
    linear = gp.mesh(resolution=24, refine_steps=0)
    assert np.abs(gp.mean(refined.vertices)).mean() < 0.2 * np.abs(gp.mean(linear.vertices)).mean()
    np.testing.assert_array_equal(refined.faces, linear.faces)


def test_the_loop_refuses_a_refine_steps_that_is_not_a_count():
    from explorer.loop import LoopConfig

    for bad in (-1, 1.5, True):
        with pytest.raises(ValueError, match="LoopConfig.reconstruction_refine_steps must be a count >= 0"):
            LoopConfig(reconstruction_refine_steps=bad)
    assert LoopConfig(reconstruction_refine_steps=2).reconstruction_refine_steps == 2


def _disc_contacts(n, seed, radius=0.05, half_thickness=0.003):
    """(n, 3) points and outward normals spread by area over a flat disc's faces and rim, metres."""
    rng = np.random.default_rng(seed)
    face, rim = np.pi * radius**2, 2 * np.pi * radius * 2 * half_thickness
    k_rim = int(round(n * rim / (2 * face + rim)))
    k_face = (n - k_rim) // 2
    points, normals = [], []
    for side in (1.0, -1.0):
        r, a = radius * np.sqrt(rng.random(k_face)), 2 * np.pi * rng.random(k_face)
        points.append(np.column_stack([r * np.cos(a), r * np.sin(a), np.full(k_face, side * half_thickness)]))
        normals.append(np.tile([0.0, 0.0, side], (k_face, 1)))
    a, z = 2 * np.pi * rng.random(k_rim), half_thickness * (2 * rng.random(k_rim) - 1)
    points.append(np.column_stack([radius * np.cos(a), radius * np.sin(a), z]))
    normals.append(np.column_stack([np.cos(a), np.sin(a), np.zeros(k_rim)]))
    return np.vstack(points), np.vstack(normals)


def _face_crossings_mm(model, half_thickness=0.003, lines=12):
    """The zero crossings of ``model``'s mean on vertical lines through a disc's middle, minus the
    faces' true heights, mm (linear interpolation on a 0.05 mm grid)."""
    z = np.arange(-0.008, 0.008 + 1e-9, 5e-5)
    errors = []
    for x, y in np.random.default_rng(2).uniform(-0.025, 0.025, (lines, 2)):
        f = model.mean(np.column_stack([np.full_like(z, x), np.full_like(z, y), z]))
        for side, keep in ((1.0, z > 0), (-1.0, z < 0)):
            zs, fs = z[keep], f[keep]
            i = np.flatnonzero(np.sign(fs[:-1]) != np.sign(fs[1:]))
            assert len(i) == 1, "one face crossing per side"
            j = i[0]
            crossing = zs[j] - fs[j] * (zs[j + 1] - zs[j]) / (fs[j + 1] - fs[j])
            errors.append(1e3 * (crossing - side * half_thickness))
    return np.asarray(errors)


def test_the_images_kernel_keeps_a_densely_imaged_thin_wall_at_its_faces():
    """Exact contacts of a 6 mm disc and 600 exact images 5 mm apart: under the image kernel
    (Matern-3/2) the faces' zero crossings lie within 0.01 mm of the truth, and the thin plate's
    field, whose R spans the workspace, rings between the images and misplaces them several times
    more (BENCHMARKS.md, "The images' kernel")."""
    bounds = ((-0.07, -0.07, -0.03), (0.07, 0.07, 0.03))
    points, normals = _disc_contacts(100, seed=0)
    images, image_normals = _disc_contacts(600, seed=1)
    rms = {}
    for kernel in ("matern32", None):
        gp = GPIS(bounds=bounds, image_kernel=kernel).fit(points, normals)
        model = gp._observing(images, image_normals)
        assert model is not gp and gp.n_contacts == len(points)
        assert type(model.kernel).__name__ == ("Matern32Kernel" if kernel else "ThinPlateKernel")
        rms[kernel] = float(np.sqrt(np.mean(_face_crossings_mm(model) ** 2)))
    assert rms["matern32"] < 0.01
    assert rms["matern32"] < 0.3 * rms[None]


def test_the_images_model_is_one_fit_of_contacts_and_images_under_the_image_kernel():
    """Refactored under the image kernel and then extended by the images, the copy's mean is the
    mean of one fit of contacts and images with that kernel (no opposing normals on a sphere, so
    both give every row the same noise)."""
    from reconstruction.kernels import Matern32Kernel

    kernel = Matern32Kernel(0.06, 0.06 / np.sqrt(3.0))
    points, normals = sphere_contacts(40, seed=3)
    images, image_normals = sphere_contacts(60, seed=4)
    model = GPIS(bounds=BOUNDS, image_kernel=kernel).fit(points, normals)._observing(images, image_normals)
    once = GPIS(bounds=BOUNDS, kernel=kernel).fit(np.vstack([points, images]), np.vstack([normals, image_normals]))
    x = 0.9 * RADIUS * random_directions(50, 5)
    assert np.allclose(model.mean(x), once.mean(x), atol=1e-7)
    assert model.kernel is kernel


def test_the_image_kernel_is_validated_and_copied():
    with pytest.raises(ValueError, match="image_kernel"):
        GPIS(image_kernel="nope")
    with pytest.raises(ValueError, match="image_kernel"):
        GPIS(image_kernel=3)
    assert GPIS(image_kernel=None).unfitted_copy().image_kernel is None
    assert GPIS().image_kernel == "matern32"
