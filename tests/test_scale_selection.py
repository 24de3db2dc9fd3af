"""Data-chosen length scale: the marginal likelihood recovers the scale of a known GP draw."""
import numpy as np
import pytest

from reconstruction.gpis import GPIS
from reconstruction.kernels import Matern32Kernel, Matern52Kernel
from reconstruction.scale_selection import choose_length_scale

BOUNDS = ((-0.06, -0.06, -0.06), (0.06, 0.06, 0.06))
NOISE = 1e-4


def _gp_draw(kernel, n, seed):
    """Values of one draw of a GP with ``kernel`` at n random points, given f = 0 and
    grad f = -(1, 0, 0) at the origin (the one contact the GPIS needs first)."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(-0.05, 0.05, (n, 3))
    anchor = np.zeros((1, 3))
    K_aa = kernel.joint_covariance(anchor, anchor).reshape(4, 4)
    K_xa = kernel.joint_covariance(x, anchor)[:, 0].reshape(n, 4)
    K_xx = kernel.value(x, x)
    y_a = np.array([0.0, -1.0, 0.0, 0.0])
    mean = K_xa @ np.linalg.solve(K_aa, y_a)
    cov = K_xx - K_xa @ np.linalg.solve(K_aa, K_xa.T)
    L = np.linalg.cholesky(cov + 1e-12 * np.eye(n))
    return x, mean + L @ rng.normal(size=n) + NOISE * rng.normal(size=n)


@pytest.mark.parametrize("family,true_length", [(Matern52Kernel, 0.02), (Matern52Kernel, 0.04),
                                                (Matern32Kernel, 0.03)])
def test_marginal_likelihood_recovers_the_length_scale_of_a_draw(family, true_length):
    make = lambda length: family(length, 0.01)  # noqa: E731
    x, values = _gp_draw(make(true_length), 250, seed=1)

    def fit(kernel):
        gp = GPIS(kernel=kernel, bounds=BOUNDS, trend=None, noise=NOISE, normal_noise=1e-3)
        return gp.fit(np.zeros((1, 3)), np.array([[1.0, 0.0, 0.0]])).add_values(x, values)

    lengths = true_length * np.array([0.25, 0.5, 0.7, 1.0, 1.4, 2.0, 4.0])
    best, scores = choose_length_scale(fit, make, lengths)
    assert best == pytest.approx(true_length)
    assert np.all(np.isfinite(scores))


def test_log_marginal_likelihood_matches_the_dense_gaussian_density():
    from scipy.stats import multivariate_normal

    kernel = Matern52Kernel(0.03, 0.02)
    x, values = _gp_draw(kernel, 40, seed=2)
    gp = GPIS(kernel=kernel, bounds=BOUNDS, trend=None, noise=NOISE, normal_noise=1e-3)
    gp.fit(np.zeros((1, 3)), np.array([[1.0, 0.0, 0.0]])).add_values(x, values)
    points = np.vstack([np.zeros((1, 3)), x])
    full = kernel.joint_covariance(points, points)
    rows = [(0, c) for c in range(4)] + [(i, 0) for i in range(1, 41)]
    K = np.array([[full[i, a, j, b] for j, b in rows] for i, a in rows])
    K += np.diag([NOISE**2] + [1e-6] * 3 + [NOISE**2] * 40)
    y = np.concatenate([[0.0, -1.0, 0.0, 0.0], values])
    expected = multivariate_normal(np.zeros(len(y)), K).logpdf(y)
    assert gp.log_marginal_likelihood() == pytest.approx(expected, rel=1e-8)


def test_bad_candidates_are_rejected():
    with pytest.raises(ValueError, match="positive finite"):
        choose_length_scale(lambda k: None, lambda length: Matern52Kernel(length), [0.01, -1.0])
