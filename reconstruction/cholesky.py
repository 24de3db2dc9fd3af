"""A Cholesky factor that grows by appending rows, without refactoring or copying per append.

``L`` (lower, n x n) is kept as three contiguous pieces::

        [ A  0 ]     A : (n0, n0)  factor at the last consolidation
    L = [ P  T ]     P : (k, n0)   rows appended since, left part (rows of a preallocated buffer)
                     T : (k, k)    rows appended since, lower-triangular right part

Triangular solves then run on contiguous memory (a strided view of a larger buffer would be copied
by LAPACK wrappers, costing more than the solve). When ``k`` reaches ``tail_capacity`` the pieces
are merged into a new ``A`` (one n^2 copy, amortised over many appends).
"""
from __future__ import annotations

import numpy as np
import torch


class NotPositiveDefiniteError(np.linalg.LinAlgError):
    """The matrix (or the Schur complement of an appended block) is not positive definite."""


class GrowingCholesky:
    """Lower Cholesky factor of a symmetric positive definite matrix that grows by blocks.

    Parameters
    ----------
    matrix : (n, n) float
        Initial symmetric positive definite matrix (may be 0 x 0).
    tail_capacity : int
        Rows appended before the factor is consolidated into one contiguous block. A block larger
        than this goes straight into the consolidated factor.
    """

    def __init__(self, matrix: np.ndarray, tail_capacity: int = 512):
        self.tail_capacity = int(tail_capacity)
        self._A = _cholesky(torch.as_tensor(np.asarray(matrix, dtype=np.float64)))
        self._reset_tail()

    @property
    def n(self) -> int:
        """Current size."""
        return self._n0 + self._k

    def _reset_tail(self) -> None:
        self._n0 = self._A.shape[0]
        self._k = 0
        self._P = torch.zeros((self.tail_capacity, self._n0), dtype=torch.float64)
        self._T = torch.zeros((self.tail_capacity, self.tail_capacity), dtype=torch.float64)

    def append(self, cross: np.ndarray, block: np.ndarray) -> np.ndarray:
        """Grow the factored matrix to ``[[K, cross], [cross^T, block]]``.

        Parameters
        ----------
        cross : (n, b) float
        block : (b, b) float, symmetric

        Returns
        -------
        (b, n + b) float
            The new rows of ``L``.

        Raises
        ------
        NotPositiveDefiniteError
            If the grown matrix is not positive definite; the factor is then unchanged.
        """
        cross = torch.as_tensor(np.asarray(cross, dtype=np.float64))
        block = torch.as_tensor(np.asarray(block, dtype=np.float64))
        b = block.shape[0]
        if cross.shape != (self.n, b):
            raise ValueError(f"cross must be ({self.n}, {b}), got {tuple(cross.shape)}")
        S = self._solve_lower(cross)
        M = _cholesky(block - S.T @ S)  # raises before any state changes: a failed append is a no-op
        if self._k + b > self.tail_capacity:
            self._consolidate()
        if b > self.tail_capacity:
            # Larger than the tail buffers: place the block directly into the consolidated factor.
            n0 = self._n0
            A = torch.zeros((n0 + b, n0 + b), dtype=torch.float64)
            A[:n0, :n0] = self._A
            A[n0:, :n0] = S.T
            A[n0:, n0:] = M
            self._A = A
            self._reset_tail()
            return torch.cat([S.T, M], dim=1).numpy()
        k0, k1 = self._k, self._k + b
        self._P[k0:k1] = S[: self._n0].T
        self._T[k0:k1, :k0] = S[self._n0:].T
        self._T[k0:k1, k0:k1] = M
        self._k = k1
        return torch.cat([S.T, M], dim=1).numpy()

    def truncate(self, n: int) -> None:
        """Shrink to the factor of the leading ``n x n`` block (undoes appends beyond ``n``)."""
        if not 0 <= n <= self.n:
            raise ValueError(f"cannot truncate a factor of size {self.n} to {n}")
        if n >= self._n0:
            self._k = n - self._n0
            return
        self._A = self._A[:n, :n].clone()
        self._reset_tail()

    def rows(self, start: int, stop: int) -> np.ndarray:
        """``L[start:stop, :stop]`` as a new array, (stop - start, stop) float."""
        if not 0 <= start <= stop <= self.n:
            raise ValueError(f"rows {start}:{stop} outside 0:{self.n}")
        out = torch.zeros((stop - start, stop), dtype=torch.float64)
        a0, a1 = min(start, self._n0), min(stop, self._n0)
        if a1 > a0:
            out[: a1 - a0, :a1] = self._A[a0:a1, :a1]
        t0, t1 = max(start, self._n0) - self._n0, stop - self._n0
        if t1 > t0:
            r = slice(max(start, self._n0) - start, stop - start)
            out[r, : self._n0] = self._P[t0:t1]
            out[r, self._n0:stop] = self._T[t0:t1, :t1]
        return out.numpy()

    def solve_lower(self, rhs: np.ndarray) -> np.ndarray:
        """``L^-1 rhs`` for rhs (n,) or (n, r)."""
        return self._apply(self._solve_lower, rhs)

    def solve_upper(self, rhs: np.ndarray) -> np.ndarray:
        """``L^-T rhs`` for rhs (n,) or (n, r)."""
        return self._apply(self._solve_upper, rhs)

    def dense(self) -> np.ndarray:
        """The whole factor as an (n, n) array (for tests and small problems)."""
        return self.rows(0, self.n)

    def _apply(self, solve, rhs):
        rhs = np.asarray(rhs, dtype=np.float64)
        if rhs.shape[0] != self.n:
            raise ValueError(f"right-hand side has {rhs.shape[0]} rows, factor has {self.n}")
        vector = rhs.ndim == 1
        out = solve(torch.as_tensor(rhs.reshape(self.n, -1)))
        return out.numpy().reshape(rhs.shape) if vector else out.numpy()

    def _solve_lower(self, rhs: torch.Tensor) -> torch.Tensor:
        n0, k = self._n0, self._k
        top = torch.linalg.solve_triangular(self._A, rhs[:n0], upper=False) if n0 else rhs[:0]
        if not k:
            return top
        T = self._T[:k, :k].contiguous()
        bottom = torch.linalg.solve_triangular(T, rhs[n0:] - self._P[:k] @ top, upper=False)
        return torch.cat([top, bottom])

    def _solve_upper(self, rhs: torch.Tensor) -> torch.Tensor:
        n0, k = self._n0, self._k
        if k:
            T = self._T[:k, :k].contiguous()
            bottom = torch.linalg.solve_triangular(T.T, rhs[n0:], upper=True)
            top_rhs = rhs[:n0] - self._P[:k].T @ bottom
        else:
            bottom, top_rhs = rhs[n0:], rhs[:n0]
        top = torch.linalg.solve_triangular(self._A.T, top_rhs, upper=True) if n0 else top_rhs
        return torch.cat([top, bottom])

    def _consolidate(self) -> None:
        if not self._k:
            return
        n0, k = self._n0, self._k
        A = torch.zeros((n0 + k, n0 + k), dtype=torch.float64)
        A[:n0, :n0] = self._A
        A[n0:, :n0] = self._P[:k]
        A[n0:, n0:] = self._T[:k, :k]
        self._A = A
        self._reset_tail()


def _cholesky(matrix: torch.Tensor) -> torch.Tensor:
    if matrix.shape[0] == 0:
        return matrix.clone()
    L, info = torch.linalg.cholesky_ex(matrix)
    if int(info) != 0:
        raise NotPositiveDefiniteError(
            f"matrix is not positive definite (leading minor {int(info)} of {matrix.shape[0]} failed); "
            "for GPIS this means the kernel is indefinite for these points or the noise is too small")
    return L
