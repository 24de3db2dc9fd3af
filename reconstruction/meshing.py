"""Meshing the 0-level set of an implicit function with coarse-to-fine evaluation.

A dense ``n^3`` grid costs ``n^3`` evaluations of the GP mean, each O(contacts). Only cells near the
surface matter: the grid is evaluated at a coarse stride first, and a cell is refined only when the
values at its corners could hide a zero crossing (a sign change, or every ``|f|`` at its corners
below a Lipschitz bound times the cell diagonal). Points that are never evaluated get the trilinear
interpolation of the coarser level, which has the correct sign there, so marching cubes sees the
same 0-level set as on the dense grid.

Marching cubes places each vertex on its grid edge by linear interpolation of the two corner
values. Across a thin wall the field rises and falls within a few millimetres (a narrow parabola
between the wall's faces), and the straight line between a corner outside and a corner inside
crosses zero inside the wall: the mesh shrank by a third of a voxel there, more as contacts grew
denser and the field followed the wall more closely (BENCHMARKS.md, issue 10). Each vertex is
therefore moved to the zero of ``func`` on its edge by a few steps of regula falsi
(``refine_steps``), which keeps the mesh's connectivity and stays on the edge. A vertex whose zero
lies within ``MIN_REFINE_MOVE`` of a voxel of the linear estimate stays where it was: on a smooth
surface the linear vertices give smoother faces (moving every vertex raised the registry sphere's
normal error from 3.4 to 4.1 deg, with this threshold 3.6), and the thin walls' vertices move
further than that.
"""
from __future__ import annotations

from typing import Callable

import numpy as np

#: Safety factor on the gradient magnitude estimated from the coarsest grid.
LIPSCHITZ_MARGIN = 1.5
#: Evaluations per vertex that move it along its edge to the zero (module docstring).
DEFAULT_REFINE_STEPS = 2
#: A vertex moves only if the zero lies this fraction of a voxel or more from the linear estimate.
MIN_REFINE_MOVE = 0.1


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
                    coarse_to_fine: bool = True, refine_steps: int = DEFAULT_REFINE_STEPS):
    """Marching-cubes mesh of ``{x : func(x) = 0}`` with outward normals (``func > 0`` inside).

    Parameters
    ----------
    func : callable, (m, 3) float -> (m,) float
    bounds : ((3,), (3,)) float, metres
    resolution : int
        Samples along the longest side.
    refine_steps : int
        Evaluations of ``func`` per vertex that move it along its grid edge towards the zero
        (module docstring); 0: the linear interpolation of marching cubes.

    Returns
    -------
    trimesh.Trimesh
        In the frame of ``bounds``; faces wound so that normals point to ``func < 0``.
    """
    import trimesh
    from skimage.measure import marching_cubes

    check_refine_steps(refine_steps)
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
    verts, faces, _, _ = marching_cubes(values, level=0.0, gradient_direction="ascent")
    origin = np.array([a[0] for a in axes])
    if refine_steps:
        verts = _refined_on_edges(func, values, verts, origin, step, int(refine_steps))
    else:
        verts = origin + step * verts
    return trimesh.Trimesh(vertices=verts, faces=faces, process=True)


def check_refine_steps(value, name: str = "refine_steps") -> None:
    """Refuse a ``refine_steps`` that is not a count >= 0, naming it ``name``."""
    if not (isinstance(value, (int, np.integer)) and not isinstance(value, bool) and value >= 0):
        raise ValueError(f"{name} must be a count >= 0, got {value!r}")


def _refined_on_edges(func, values: np.ndarray, verts: np.ndarray, origin: np.ndarray, step: float,
                      steps: int) -> np.ndarray:
    """Vertices (k, 3), grid index units, moved along their grid edges to the zero of ``func`` by
    ``steps`` Illinois regula-falsi evaluations where the zero lies ``MIN_REFINE_MOVE`` of a voxel or
    more from them; returned in metres. The corner values bracket the zero (marching cubes put the
    vertex between a corner >= 0 and one < 0)."""
    low = np.floor(verts).astype(np.int64)
    frac = verts - low
    axis = np.argmax(frac, axis=1)
    on_edge = frac[np.arange(len(verts)), axis] > 0  # a vertex on a corner is exact already
    idx = np.flatnonzero(on_edge)
    out = origin + step * verts
    if not len(idx):
        return out
    a_idx = low[idx]
    b_idx = a_idx.copy()
    b_idx[np.arange(len(idx)), axis[idx]] += 1
    f_a = values[tuple(a_idx.T)].astype(float)
    f_b = values[tuple(b_idx.T)].astype(float)
    t_a, t_b = np.zeros(len(idx)), np.ones(len(idx))
    t = frac[idx, axis[idx]]
    direction = np.zeros((len(idx), 3))
    direction[np.arange(len(idx)), axis[idx]] = step
    start = origin + step * a_idx
    moved_a = np.zeros(len(idx), int)  # which end the last step replaced: 1 a, -1 b, 0 none yet
    for _ in range(steps):
        f_t = np.asarray(func(start + t[:, None] * direction), float)
        same_as_a = (f_t >= 0) == (f_a >= 0)
        # Illinois: the end kept twice in a row has its value halved, so that a curved profile
        # (regula falsi's slow side) still shrinks the bracket from both ends
        f_b = np.where(same_as_a & (moved_a == 1), 0.5 * f_b, f_b)
        f_a = np.where(~same_as_a & (moved_a == -1), 0.5 * f_a, f_a)
        t_a, f_a = np.where(same_as_a, t, t_a), np.where(same_as_a, f_t, f_a)
        t_b, f_b = np.where(same_as_a, t_b, t), np.where(same_as_a, f_b, f_t)
        moved_a = np.where(same_as_a, 1, -1)
        denominator = f_a - f_b
        safe = np.abs(denominator) > 0
        t = np.where(safe, t_a + (t_b - t_a) * f_a / np.where(safe, denominator, 1.0), 0.5 * (t_a + t_b))
        t = np.clip(t, t_a, t_b)
    linear = frac[idx, axis[idx]]
    moved = np.abs(t - linear) >= MIN_REFINE_MOVE
    out[idx[moved]] = start[moved] + t[moved, None] * direction[moved]
    return out
