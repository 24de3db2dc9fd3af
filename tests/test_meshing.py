"""Coarse-to-fine meshing agrees with the dense grid it replaces."""
import numpy as np
import pytest

from reconstruction import meshing
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


SLAB_BOUNDS = ((-0.05, -0.05, -0.02), (0.05, 0.05, 0.02))


def thin_slab(p, half_thickness=0.002):
    """A 4 mm wall across z = 0: the field rises and falls across it like a GPIS's across a thin
    wall (a parabola, > 0 inside), not like a distance."""
    return (half_thickness**2 - p[:, 2] ** 2) / (2 * half_thickness)


def test_vertices_moved_along_their_edges_lie_on_the_wall_not_inside_it(monkeypatch):
    # Linear interpolation of the parabola between a grid point outside and one inside crosses
    # zero inside the wall: the faces' |z| comes out below the 2 mm half thickness. Moved along
    # their edges by two evaluations each (every vertex, however little it moves) they lie within
    # a quarter of that bias of it (the closed form), and the mesh keeps its faces.
    monkeypatch.setattr(meshing, "MIN_REFINE_MOVE", 0.0)
    linear = mesh_zero_level(thin_slab, SLAB_BOUNDS, resolution=33, refine_steps=0)  # 3.1 mm voxels
    refined = mesh_zero_level(thin_slab, SLAB_BOUNDS, resolution=33)
    inward = 0.002 - np.abs(linear.vertices[:, 2])
    assert inward.mean() > 1e-4  # the bias being removed is there: over 0.1 mm on average
    assert np.abs(np.abs(refined.vertices[:, 2]) - 0.002).max() < 0.25 * inward.mean()
    np.testing.assert_array_equal(refined.faces, linear.faces)
    np.testing.assert_allclose(refined.vertices[:, :2], linear.vertices[:, :2], atol=1e-12)


def test_a_vertex_moves_only_where_the_zero_lies_a_tenth_of_a_voxel_off_the_linear_one():
    # By default a vertex whose zero lies within MIN_REFINE_MOVE of a voxel of its linear
    # estimate stays (a smooth surface keeps the smooth faces linear interpolation gives): every
    # vertex is either where it was or moved by at least that, and none is left further off the
    # wall than that plus the refinement's own tolerance.
    step = (SLAB_BOUNDS[1][0] - SLAB_BOUNDS[0][0]) / 32
    linear = mesh_zero_level(thin_slab, SLAB_BOUNDS, resolution=33, refine_steps=0)
    refined = mesh_zero_level(thin_slab, SLAB_BOUNDS, resolution=33)
    move = np.linalg.norm(refined.vertices - linear.vertices, axis=1)
    assert np.all((move == 0) | (move >= meshing.MIN_REFINE_MOVE * step * (1 - 1e-9)))
    assert 0 < np.count_nonzero(move) < len(move)
    inward = 0.002 - np.abs(linear.vertices[:, 2])
    off = np.abs(np.abs(refined.vertices[:, 2]) - 0.002)
    assert off.max() < meshing.MIN_REFINE_MOVE * step + 0.25 * inward.mean()
    assert off.mean() < 0.5 * inward.mean()


@pytest.mark.parametrize("func", [torus, two_spheres])
def test_refined_vertices_are_nearer_the_zero_than_interpolated_ones(func, monkeypatch):
    monkeypatch.setattr(meshing, "MIN_REFINE_MOVE", 0.0)
    linear = mesh_zero_level(func, BOUNDS, resolution=33, refine_steps=0)
    refined = mesh_zero_level(func, BOUNDS, resolution=33)
    assert np.abs(func(refined.vertices)).mean() < 0.1 * np.abs(func(linear.vertices)).mean()
    assert np.abs(func(refined.vertices)).max() < 0.5 * np.abs(func(linear.vertices)).max()


def test_refine_steps_must_be_a_count():
    with pytest.raises(ValueError, match="refine_steps must be a count >= 0"):
        mesh_zero_level(torus, BOUNDS, resolution=33, refine_steps=-1)
