"""Contract tests every registered kernel passes (in the style of gpytorch's BaseKernelTestCase):
derivative blocks against finite differences, symmetry, the radial functions against derivatives
of ``phi``, positive definiteness exactly where the kernel declares it; then the thin-plate claims."""
import numpy as np
import pytest

from reconstruction.kernels import (KERNELS, Kernel, Matern52Kernel, ReferenceThinPlateKernel,
                                    SquaredExponentialKernel, SumKernel, ThinPlateKernel, kernel_names,
                                    make_kernel, register_kernel)

#: The workspace every registered kernel is built for: a 10 cm cube (diagonal 0.17 m).
HALF_SIDE = 0.05
DIAGONAL = float(np.linalg.norm([2 * HALF_SIDE] * 3))
KERNEL_INSTANCES = [make_kernel(name, DIAGONAL, DIAGONAL) for name in kernel_names()] + [
    ThinPlateKernel(0.3), SquaredExponentialKernel(0.05, 0.7), Matern52Kernel(0.01, 0.02),
    SumKernel(ThinPlateKernel(0.3), Matern52Kernel(0.02, 0.01))]
IDS = [f"{k.name}-{k!r}" for k in KERNEL_INSTANCES]
H = 1e-6


@pytest.fixture
def pairs():
    rng = np.random.default_rng(1)
    x = rng.uniform(-HALF_SIDE, HALF_SIDE, (6, 3))
    y = rng.uniform(-HALF_SIDE, HALF_SIDE, (5, 3))
    return x, y


def _fd_gradient(fn, x, y):
    """Central differences of fn(x, y) -> (m, n, ...) with respect to x, appended as last axis."""
    out = []
    for a in range(3):
        e = np.zeros(3)
        e[a] = H
        out.append((fn(x + e, y) - fn(x - e, y)) / (2 * H))
    return np.stack(out, axis=-1)


def _scale(kernel):
    """Typical size of the kernel's values in the workspace, for absolute tolerances."""
    return max(abs(kernel.prior_variance), 1e-12)


@pytest.mark.parametrize("kernel", KERNEL_INSTANCES, ids=IDS)
class TestKernelContract:
    def test_declares_its_properties(self, kernel):
        assert isinstance(kernel, Kernel)
        assert isinstance(kernel.positive_definite, bool)
        assert isinstance(kernel.grows_with_workspace, bool)

    def test_gradient_matches_finite_differences(self, kernel, pairs):
        x, y = pairs
        np.testing.assert_allclose(kernel.gradient(x, y), _fd_gradient(kernel.value, x, y),
                                   rtol=1e-5, atol=1e-6 * _scale(kernel))

    def test_hessian_matches_finite_differences(self, kernel, pairs):
        x, y = pairs
        np.testing.assert_allclose(kernel.hessian(x, y), _fd_gradient(kernel.gradient, x, y),
                                   rtol=1e-4, atol=1e-4 * _scale(kernel))

    def test_radial_functions_are_derivatives_of_phi(self, kernel):
        r = np.linspace(0.003, 0.15, 40)
        h = 1e-6
        d1 = (kernel.phi(r + h) - kernel.phi(r - h)) / (2 * h)
        d2 = (kernel.phi(r + h) - 2 * kernel.phi(r) + kernel.phi(r - h)) / h**2
        scale = np.max(np.abs(d1 / r))
        np.testing.assert_allclose(kernel.g(r), d1 / r, rtol=1e-5, atol=1e-6 * scale)
        np.testing.assert_allclose(kernel.q(r), d2 - d1 / r, rtol=1e-3, atol=1e-3 * scale)

    def test_joint_covariance_blocks_are_derivatives_of_the_kernel(self, kernel, pairs):
        """cov(f(x), df(y)/dy) = dk/dy, cov(df/dx, f(y)) = dk/dx, cov(df/dx, df/dy) = d2k/dxdy,
        each by finite differences of the value alone (no shared formula with the code)."""
        x, y = pairs
        K = kernel.joint_covariance(x, y)
        k = kernel.value
        dk_dx = _fd_gradient(k, x, y)
        dk_dy = _fd_gradient(lambda b, a: k(a, b), y, x)
        d2k = np.stack([_fd_gradient(lambda a, b, e=e: (k(a, b + e) - k(a, b - e)) / (2 * H), x, y)
                        for e in np.eye(3) * H], axis=-1)  # [i, j, a(x), b(y)]
        s = _scale(kernel)
        np.testing.assert_allclose(K[:, 0, :, 0], k(x, y))
        np.testing.assert_allclose(K[:, 0, :, 1:], dk_dy, rtol=1e-5, atol=1e-6 * s)
        np.testing.assert_allclose(K[:, 1:, :, 0].transpose(0, 2, 1), dk_dx, rtol=1e-5, atol=1e-6 * s)
        np.testing.assert_allclose(K[:, 1:, :, 1:].transpose(0, 2, 1, 3), d2k, rtol=1e-3,
                                   atol=1e-2 * s)

    def test_joint_covariance_is_symmetric(self, kernel, pairs):
        x, y = pairs
        np.testing.assert_allclose(kernel.joint_covariance(x, y),
                                   kernel.joint_covariance(y, x).transpose(2, 3, 0, 1),
                                   atol=1e-12 * _scale(kernel))

    def test_blocks_are_finite_at_zero_distance(self, kernel):
        x = np.array([[0.01, 0.02, 0.03]])
        K = kernel.joint_covariance(x, x)[0, :, 0, :]
        assert np.all(np.isfinite(K))
        np.testing.assert_allclose(K[0, 1:], 0, atol=1e-15)
        assert K[0, 0] == pytest.approx(kernel.prior_variance)

    def test_positive_definite_exactly_when_declared(self, kernel):
        """Value and gradient observations at random workspace points: the Gram matrix's smallest
        eigenvalue has the sign the kernel declares."""
        points = np.random.default_rng(0).uniform(-HALF_SIDE, HALF_SIDE, (40, 3))
        smallest = np.linalg.eigvalsh(_gram(kernel, points)).min()
        if kernel.positive_definite:
            assert smallest > -1e-9 * np.abs(_gram(kernel, points)).max()
            np.linalg.cholesky(_gram(kernel, points) + 1e-8 * np.eye(160) * _scale(kernel))
        else:
            assert smallest < 0


def test_registry_names_build_their_classes():
    for name, cls in KERNELS.items():
        kernel = make_kernel(name, DIAGONAL, 0.1)
        assert type(kernel) is cls and kernel.name == name


def test_registry_rejects_unknown_names_and_clashes():
    with pytest.raises(ValueError, match="unknown kernel 'nope'; choose one of thin_plate"):
        make_kernel("nope", DIAGONAL)
    with pytest.raises(ValueError, match="already registered"):
        register_kernel("thin_plate")(SquaredExponentialKernel)
    with pytest.raises(TypeError):
        register_kernel("not_a_kernel")(int)


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
