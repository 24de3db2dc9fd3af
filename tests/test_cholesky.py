import numpy as np
import pytest

from reconstruction.cholesky import GrowingCholesky, NotPositiveDefiniteError


def _spd(n, seed=0):
    x = np.random.default_rng(seed).normal(size=(n, n))
    return x @ x.T + n * np.eye(n)


@pytest.mark.parametrize("tail_capacity", [4, 9, 512])
def test_appending_blocks_reproduces_the_full_factor(tail_capacity):
    """Including across consolidations (small tail capacities force several)."""
    K = _spd(41)
    factor = GrowingCholesky(K[:5, :5], tail_capacity=tail_capacity)
    i = 5
    while i < len(K):
        b = min(4, len(K) - i)
        factor.append(K[:i, i:i + b], K[i:i + b, i:i + b])
        i += b
    L = np.linalg.cholesky(K)
    np.testing.assert_allclose(factor.dense(), L, atol=1e-12)
    rhs = np.random.default_rng(1).normal(size=(41, 3))
    np.testing.assert_allclose(factor.solve_lower(rhs), np.linalg.solve(L, rhs), atol=1e-12)
    np.testing.assert_allclose(factor.solve_upper(rhs), np.linalg.solve(L.T, rhs), atol=1e-12)
    np.testing.assert_allclose(factor.rows(7, 30), L[7:30, :30], atol=1e-12)


def test_append_returns_the_new_rows():
    K = _spd(12)
    factor = GrowingCholesky(K[:8, :8])
    rows = factor.append(K[:8, 8:], K[8:, 8:])
    np.testing.assert_allclose(rows, np.linalg.cholesky(K)[8:], atol=1e-12)


def test_not_positive_definite_is_a_named_error():
    with pytest.raises(NotPositiveDefiniteError, match="not positive definite"):
        GrowingCholesky(np.array([[1.0, 2.0], [2.0, 1.0]]))
    factor = GrowingCholesky(np.eye(2))
    with pytest.raises(NotPositiveDefiniteError):
        factor.append(np.array([[1.0], [0.0]]), np.array([[0.5]]))


def test_shape_mismatch_is_rejected():
    factor = GrowingCholesky(np.eye(3))
    with pytest.raises(ValueError, match="cross must be"):
        factor.append(np.zeros((2, 1)), np.eye(1))
    with pytest.raises(ValueError, match="rows"):
        factor.solve_lower(np.zeros(4))


@pytest.mark.parametrize("start", [0, 5, 30])
def test_a_block_larger_than_the_tail_capacity_is_appended(start):
    K = _spd(60, seed=4)
    factor = GrowingCholesky(K[:3, :3], tail_capacity=8)
    factor.append(K[:3, 3:start + 3], K[3:start + 3, 3:start + 3]) if start else None
    n = factor.n
    rows = factor.append(K[:n, n:n + 20], K[n:n + 20, n:n + 20])  # 20 > 8
    L = np.linalg.cholesky(K[:n + 20, :n + 20])
    np.testing.assert_allclose(rows, L[n:], atol=1e-12)
    np.testing.assert_allclose(factor.dense(), L, atol=1e-12)
    factor.append(K[:n + 20, n + 20:], K[n + 20:, n + 20:])  # and it keeps growing afterwards
    np.testing.assert_allclose(factor.dense(), np.linalg.cholesky(K), atol=1e-12)


def test_a_failed_append_leaves_the_factor_unchanged():
    K = _spd(10)
    factor = GrowingCholesky(K[:6, :6], tail_capacity=2)
    before = factor.dense()
    bad_block = K[6:, 6:] - 1e3 * np.eye(4)
    with pytest.raises(NotPositiveDefiniteError):
        factor.append(K[:6, 6:], bad_block)
    assert factor.n == 6
    np.testing.assert_array_equal(factor.dense(), before)
    factor.append(K[:6, 6:], K[6:, 6:])
    np.testing.assert_allclose(factor.dense(), np.linalg.cholesky(K), atol=1e-12)


@pytest.mark.parametrize("keep", [2, 5, 9])
def test_truncate_undoes_appends(keep):
    K = _spd(12, seed=2)
    factor = GrowingCholesky(K[:4, :4], tail_capacity=3)
    for i in range(4, 12, 2):
        factor.append(K[:i, i:i + 2], K[i:i + 2, i:i + 2])
    factor.truncate(keep)
    np.testing.assert_allclose(factor.dense(), np.linalg.cholesky(K[:keep, :keep]), atol=1e-12)
    factor.append(K[:keep, keep:], K[keep:, keep:])
    np.testing.assert_allclose(factor.dense(), np.linalg.cholesky(K), atol=1e-12)
