"""Coarse-to-fine meshing agrees with the dense grid it replaces."""
import numpy as np
import pytest

from reconstruction.meshing import (evaluate_coarse_to_fine, evaluate_dense, grid_axes,
                                    mesh_zero_level)

BOUNDS = ((-0.08, -0.08, -0.06), (0.08, 0.08, 0.06))


def torus(p, R=0.05, r=0.015):
    q = np.stack([np.hypot(p[:, 0], p[:, 1]) - R, p[:, 2]], axis=1)
    return r - np.linalg.norm(q, axis=1)


def two_spheres(p):
    a = 0.03 - np.linalg.norm(p - [0.03, 0, 0], axis=1)
    b = 0.02 - np.linalg.norm(p + [0.04, 0, 0], axis=1)
    return np.maximum(a, b)


@pytest.mark.parametrize("func", [torus, two_spheres])
@pytest.mark.parametrize("resolution", [33, 64, 100])
def test_coarse_to_fine_has_the_signs_of_the_dense_grid(func, resolution):
    axes = grid_axes(BOUNDS, resolution)
    dense = evaluate_dense(func, axes)
    fine, evaluations = evaluate_coarse_to_fine(func, axes)
    assert fine.shape == dense.shape
    clear = np.abs(dense) > 1e-9  # exact zeros may come out as +-1e-17 from another summation order
    assert np.array_equal(fine[clear] > 0, dense[clear] > 0)
    near = np.abs(dense) < 2 * (axes[0][1] - axes[0][0])
    np.testing.assert_allclose(fine[near], dense[near], atol=1e-7)
    if resolution >= 64:
        assert evaluations < 0.5 * dense.size


def test_mesh_is_the_torus_with_outward_normals():
    mesh = mesh_zero_level(torus, BOUNDS, resolution=80)
    assert mesh.is_watertight
    assert mesh.volume == pytest.approx(2 * np.pi**2 * 0.05 * 0.015**2, rel=0.02)
    assert np.abs(torus(mesh.vertices)).max() < 2e-4


def test_resolution_must_be_usable():
    with pytest.raises(ValueError, match="resolution"):
        grid_axes(BOUNDS, 4)
