"""Meshing the 0-level set of an implicit function with coarse-to-fine evaluation.

A dense ``n^3`` grid costs ``n^3`` evaluations of the GP mean, each O(contacts). Only cells near the
surface matter: the grid is evaluated at a coarse stride first, and a cell is refined only when the
values at its corners could hide a zero crossing (a sign change, or every ``|f|`` at its corners
below a Lipschitz bound times the cell diagonal). Points that are never evaluated get the trilinear
interpolation of the coarser level, which has the correct sign there, so marching cubes sees the
same 0-level set as on the dense grid.
"""
from __future__ import annotations

from typing import Callable

import numpy as np

#: Safety factor on the gradient magnitude estimated from the coarsest grid.
LIPSCHITZ_MARGIN = 1.5


def grid_axes(bounds, resolution: int) -> list[np.ndarray]:
    """Sample coordinates along x, y, z with cubic voxels; ``resolution`` along the longest side."""
    lo, hi = (np.asarray(b, float) for b in bounds)
    if int(resolution) < 8:
        raise ValueError(f"resolution must be at least 8 samples, got {resolution}")
    step = float(np.max(hi - lo)) / (int(resolution) - 1)
    return [lo[i] + step * np.arange(int(round((hi[i] - lo[i]) / step)) + 1) for i in range(3)]


def evaluate_dense(func: Callable[[np.ndarray], np.ndarray], axes) -> np.ndarray:
    """``func`` at every grid point; (nx, ny, nz) float32."""
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    return np.asarray(func(grid), np.float32).reshape([len(a) for a in axes])


def evaluate_coarse_to_fine(func: Callable[[np.ndarray], np.ndarray], axes,
                            coarsest_stride: int = 8) -> tuple[np.ndarray, int]:
    """``func`` on the grid, evaluated only where a zero crossing is possible.

    Returns
    -------
    values : (nx, ny, nz) float32
    evaluations : int
        How many points were actually evaluated.
    """
    shape = np.array([len(a) for a in axes])
    stride = int(coarsest_stride)
    while stride > 1 and np.any((shape - 1) // stride < 2):
        stride //= 2
    # Pad the grid up to a multiple of the coarsest stride so every level nests exactly.
    padded = ((shape - 1 + stride - 1) // stride) * stride + 1
    step = axes[0][1] - axes[0][0]
    full_axes = [a[0] + step * np.arange(n) for a, n in zip(axes, padded)]
    values = np.zeros(padded, np.float32)
    known = np.zeros(padded, bool)

    coarse_idx = [np.arange(0, n, stride) for n in padded]
    values[np.ix_(*coarse_idx)] = _evaluate(func, full_axes, coarse_idx)
    known[np.ix_(*coarse_idx)] = True
    evaluations = int(np.prod([len(i) for i in coarse_idx]))
    coarse = values[np.ix_(*coarse_idx)]
    slope = max(float(np.max(np.abs(np.diff(coarse, axis=ax)))) / (stride * step)
                for ax in range(3))
    lipschitz = LIPSCHITZ_MARGIN * max(slope, 1e-12)

    while stride > 1:
        level = values[::stride, ::stride, ::stride]
        cells = _cells_needing_refinement(level, lipschitz * stride * step * np.sqrt(3))
        half = stride // 2
        fine = np.zeros(padded, bool)
        for offset in np.argwhere(np.ones((3, 3, 3), bool)):
            pts = cells * stride + offset * half
            fine[pts[:, 0], pts[:, 1], pts[:, 2]] = True
        todo = fine & ~known
        _interpolate_level(values, known, stride)
        idx = np.argwhere(todo)
        if len(idx):
            pts = np.column_stack([full_axes[i][idx[:, i]] for i in range(3)])
            values[idx[:, 0], idx[:, 1], idx[:, 2]] = np.asarray(func(pts), np.float32)
            evaluations += len(idx)
        known |= todo
        known[::half, ::half, ::half] = True
        stride = half
    return values[: shape[0], : shape[1], : shape[2]], evaluations


def _evaluate(func, axes, idx) -> np.ndarray:
    sub = [axes[i][idx[i]] for i in range(3)]
    return evaluate_dense(func, sub)


def _cells_needing_refinement(level: np.ndarray, bound: float) -> np.ndarray:
    """Indices (k, 3) of cells of this level whose corners may hide a zero crossing."""
    corners = [level[i:level.shape[0] - 1 + i, j:level.shape[1] - 1 + j, k:level.shape[2] - 1 + k]
               for i in (0, 1) for j in (0, 1) for k in (0, 1)]
    stack = np.stack(corners)
    sign_change = (stack.min(0) <= 0) & (stack.max(0) >= 0)
    # A zero inside the cell is within one diagonal of every corner, so every |corner value| must
    # be below the bound; testing the largest one is both rigorous and tight.
    near = np.abs(stack).max(0) < bound
    return np.argwhere(sign_change | near)


def _interpolate_level(values: np.ndarray, known: np.ndarray, stride: int) -> None:
    """Fill the next level's unknown points by trilinear interpolation of this level."""
    half = stride // 2
    level = values[::stride, ::stride, ::stride]
    fine = np.zeros([(n - 1) * 2 + 1 for n in level.shape], np.float32)
    fine[::2, ::2, ::2] = level
    fine[1::2, ::2, ::2] = 0.5 * (level[:-1] + level[1:])
    fine[:, 1::2, ::2] = 0.5 * (fine[:, :-2:2, ::2] + fine[:, 2::2, ::2])
    fine[:, :, 1::2] = 0.5 * (fine[:, :, :-2:2] + fine[:, :, 2::2])
    target = values[::half, ::half, ::half]
    mask = ~known[::half, ::half, ::half]
    target[mask] = fine[mask]


def mesh_zero_level(func: Callable[[np.ndarray], np.ndarray], bounds, resolution: int = 64,
                    coarse_to_fine: bool = True):
    """Marching-cubes mesh of ``{x : func(x) = 0}`` with outward normals (``func > 0`` inside).

    Parameters
    ----------
    func : callable, (m, 3) float -> (m,) float
    bounds : ((3,), (3,)) float, metres
    resolution : int
        Samples along the longest side.

    Returns
    -------
    trimesh.Trimesh
        In the frame of ``bounds``; faces wound so that normals point to ``func < 0``.
    """
    import trimesh
    from skimage.measure import marching_cubes

    axes = grid_axes(bounds, resolution)
    if coarse_to_fine:
        values, _ = evaluate_coarse_to_fine(func, axes)
    else:
        values = evaluate_dense(func, axes)
    if not (values.min() < 0 < values.max()):
        raise ValueError("the implicit function has no 0-level set inside the bounds "
                         f"(range {values.min():.3g} .. {values.max():.3g}); enlarge the bounds or "
                         "add contacts")
    step = axes[0][1] - axes[0][0]
    verts, faces, _, _ = marching_cubes(values, level=0.0, spacing=(step, step, step),
                                        gradient_direction="ascent")
    verts = verts + np.array([a[0] for a in axes])
    return trimesh.Trimesh(vertices=verts, faces=faces, process=True)
