"""Contract tests every kernel passes: derivative blocks against finite differences, symmetry,
and (for the thin-plate forms) the positive-definiteness claims."""
import numpy as np
import pytest

from reconstruction.kernels import (ReferenceThinPlateKernel, SquaredExponentialKernel,
                                    ThinPlateKernel)

KERNELS = [ThinPlateKernel(0.3), ReferenceThinPlateKernel(0.3), SquaredExponentialKernel(0.05, 0.7)]
IDS = [type(k).__name__ for k in KERNELS]
H = 1e-6


@pytest.fixture
def pairs():
    rng = np.random.default_rng(1)
    x = rng.uniform(-0.1, 0.1, (6, 3))
    y = rng.uniform(-0.1, 0.1, (5, 3))
    return x, y


def _fd_gradient(fn, x, y):
    """Central differences of fn(x, y) -> (m, n, ...) with respect to x, appended as last axis."""
    out = []
    for a in range(3):
        e = np.zeros(3)
        e[a] = H
        out.append((fn(x + e, y) - fn(x - e, y)) / (2 * H))
    return np.stack(out, axis=-1)


@pytest.mark.parametrize("kernel", KERNELS, ids=IDS)
def test_gradient_matches_finite_differences(kernel, pairs):
    x, y = pairs
    np.testing.assert_allclose(kernel.gradient(x, y), _fd_gradient(kernel.value, x, y),
                               rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("kernel", KERNELS, ids=IDS)
def test_hessian_matches_finite_differences(kernel, pairs):
    x, y = pairs
    np.testing.assert_allclose(kernel.hessian(x, y), _fd_gradient(kernel.gradient, x, y),
                               rtol=1e-5, atol=1e-7)


@pytest.mark.parametrize("kernel", KERNELS, ids=IDS)
def test_joint_covariance_blocks_are_derivatives_of_the_kernel(kernel, pairs):
    """cov(f(x), df(y)/dy) = dk/dy, cov(df/dx, f(y)) = dk/dx, cov(df/dx, df/dy) = d2k/dxdy,
    each by finite differences of the value alone (no shared formula with the code)."""
    x, y = pairs
    K = kernel.joint_covariance(x, y)
    k = kernel.value
    dk_dx = _fd_gradient(k, x, y)
    dk_dy = _fd_gradient(lambda b, a: k(a, b), y, x)
    d2k = np.stack([_fd_gradient(lambda a, b, e=e: (k(a, b + e) - k(a, b - e)) / (2 * H), x, y)
                    for e in np.eye(3) * H], axis=-1)  # [i, j, a(x), b(y)]
    np.testing.assert_allclose(K[:, 0, :, 0], k(x, y))
    np.testing.assert_allclose(K[:, 0, :, 1:], dk_dy, rtol=1e-5, atol=1e-8)
    np.testing.assert_allclose(K[:, 1:, :, 0].transpose(0, 2, 1), dk_dx, rtol=1e-5, atol=1e-8)
    np.testing.assert_allclose(K[:, 1:, :, 1:].transpose(0, 2, 1, 3), d2k, rtol=1e-3, atol=1e-4)


@pytest.mark.parametrize("kernel", KERNELS, ids=IDS)
def test_joint_covariance_is_symmetric(kernel, pairs):
    x, y = pairs
    np.testing.assert_allclose(kernel.joint_covariance(x, y),
                               kernel.joint_covariance(y, x).transpose(2, 3, 0, 1), atol=1e-12)


@pytest.mark.parametrize("kernel", KERNELS, ids=IDS)
def test_blocks_are_finite_at_zero_distance(kernel):
    x = np.array([[0.01, 0.02, 0.03]])
    K = kernel.joint_covariance(x, x)[0, :, 0, :]
    assert np.all(np.isfinite(K))
    np.testing.assert_allclose(K[0, 1:], 0, atol=1e-15)


def _gram(kernel, points):
    K = kernel.joint_covariance(points, points)
    n = len(points)
    return K.reshape(4 * n, 4 * n)


def test_williams_fitzgibbon_form_is_positive_definite_when_R_covers_the_workspace():
    rng = np.random.default_rng(0)
    points = rng.uniform(-0.05, 0.05, (60, 3))
    diagonal = np.linalg.norm([0.1, 0.1, 0.1])
    eig = np.linalg.eigvalsh(_gram(ThinPlateKernel(diagonal), points))
    assert eig.min() > 0


def test_williams_fitzgibbon_form_is_indefinite_with_R_the_largest_contact_distance():
    """The reference work's choice R = max distance between contacts breaks positive definiteness
    once the workspace (and so the distances) exceed it - this is why R comes from the bounds."""
    rng = np.random.default_rng(0)
    points = rng.uniform(-0.05, 0.05, (60, 3))
    spread = max(np.linalg.norm(a - b) for a in points for b in points)
    assert np.linalg.eigvalsh(_gram(ThinPlateKernel(0.3 * spread), points)).min() < 0


@pytest.mark.parametrize("R", [0.05, 0.3, 3.0])
def test_reference_form_is_indefinite_for_every_R(R):
    rng = np.random.default_rng(0)
    points = rng.uniform(-0.05, 0.05, (10, 3))
    assert np.linalg.eigvalsh(_gram(ReferenceThinPlateKernel(R), points)).min() < 0


@pytest.mark.parametrize("bad", [0.0, -1.0, np.nan, np.inf])
def test_kernel_rejects_bad_radius(bad):
    with pytest.raises(ValueError, match="radius"):
        ThinPlateKernel(bad)
