"""Chamfer distance, F-score and normal consistency against closed forms and point-cloud-utils.

point-cloud-utils (test-only dependency) is the second implementation: its own surface sampler,
exact point-to-mesh distances (libigl's AABB tree) and k-d tree, none of which this package uses.
"""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import objects
from objects.boxes import box_mesh
from reconstruction.metrics import ShapeMetrics, point_cloud_metrics, shape_metrics, surface_error

RADIUS_M = 0.05


def sphere(radius_m: float) -> trimesh.Trimesh:
    return trimesh.creation.icosphere(subdivisions=5, radius=radius_m)


@pytest.mark.parametrize("offset_mm, expected_f", [(3.0, (0.0, 0.0, 1.0)), (1.5, (0.0, 1.0, 1.0)),
                                                   (0.5, (1.0, 1.0, 1.0))])
def test_concentric_spheres_chamfer_is_the_radius_difference(offset_mm, expected_f):
    """Every point of one sphere is |r1 - r2| from the other: both Chamfer conventions give it, and
    each F-score is 1 above that distance and 0 below it."""
    inner, outer = sphere(RADIUS_M), sphere(RADIUS_M + offset_mm * 1e-3)
    # Facets sit inside the true sphere by up to the chord sagitta: at most r (1 - cos(half the
    # facet angle)) ~ 0.03 mm for a level-5 icosphere of 5 cm radius.
    sagitta_mm = 0.03
    for reconstruction, truth in ((outer, inner), (inner, outer)):
        error = surface_error(reconstruction, truth, n_samples=5000)
        assert error.chamfer_l1_mm == pytest.approx(offset_mm, abs=sagitta_mm)
        assert error.chamfer_l2_mm == pytest.approx(offset_mm, abs=sagitta_mm)
        assert (error.fscore_1mm, error.fscore_2mm, error.fscore_5mm) == expected_f
        assert error.normal_consistency > 0.999


def test_spheres_straddling_a_threshold_score_the_fraction_inside():
    """A sphere and a copy shifted by s along x: each point's distance to the other sphere is
    |s cos(theta)| to first order in s / r, with cos(theta) uniform on [-1, 1] over the area, so
    the fraction within t is t / s for t < s (precision = recall)."""
    shift_m = 0.004
    truth = sphere(RADIUS_M)
    moved = truth.copy()
    moved.apply_translation([shift_m, 0, 0])
    error = surface_error(moved, truth, n_samples=20000)
    # Second order: distance = |s cos| + s^2 sin^2 / (2 r), up to 0.16 mm; sampling: 0.4 % (1 sigma).
    assert error.fscore_1mm == pytest.approx(0.25, abs=0.03)
    assert error.fscore_2mm == pytest.approx(0.5, abs=0.03)
    assert error.fscore_5mm == 1.0
    assert error.chamfer_l1_mm == pytest.approx(shift_m * 1e3 / 2, abs=0.1)  # mean |s cos| = s / 2
    assert error.chamfer_l2_mm == pytest.approx(shift_m * 1e3 / np.sqrt(3), abs=0.1)  # rms = s / sqrt 3


def box_distances(size_m: np.ndarray, shift_m: float, n: int = 400) -> np.ndarray:
    """Area-weighted distances from the box's surface to its copy shifted by ``shift_m`` along x,
    from the analytic distance on each face (midpoint rule, n x n cells per face).

    Returns (values, weights)."""
    a, b, c = size_m
    values, weights = [], []

    def grid(u_len, v_len):
        u = (np.arange(n) + 0.5) / n * u_len - u_len / 2
        v = (np.arange(n) + 0.5) / n * v_len - v_len / 2
        uu, vv = np.meshgrid(u, v, indexing="ij")
        return uu.ravel(), vv.ravel(), np.full(n * n, u_len * v_len / n ** 2)

    y, z, w = grid(b, c)                  # -x face: outside the copy, straight across the gap
    values.append(np.full_like(y, shift_m)), weights.append(w)
    # +x face: inside the copy; nearest copy face is +x (shift), a side face, or -x (a - shift)
    values.append(np.minimum.reduce([np.full_like(y, shift_m), b / 2 - np.abs(y), c / 2 - np.abs(z),
                                     np.full_like(y, a - shift_m)])), weights.append(w)
    for side in (c, b):                   # +-y faces (a x c) and +-z faces (a x b), two of each
        x, _, w = grid(a, side)
        d = np.maximum(0.0, shift_m - (x + a / 2))  # in the copy's face plane except the first shift
        values += [d, d]
        weights += [w, w]
    return np.concatenate(values), np.concatenate(weights)


def test_box_and_its_shifted_copy_match_the_analytic_distances():
    size_m, shift_m = np.array([0.10, 0.07, 0.05]), 0.003
    truth = box_mesh(size_m, max_spacing_m=0.01)
    moved = truth.copy()
    moved.apply_translation([shift_m, 0, 0])
    d, w = box_distances(size_m, shift_m)
    mean_mm, rms_mm = 1e3 * np.average(d, weights=w), 1e3 * np.sqrt(np.average(d ** 2, weights=w))
    # The copy's distances to the truth are the mirror image, so both directions share this law.
    error = surface_error(moved, truth, n_samples=40000)
    assert error.chamfer_l1_mm == pytest.approx(mean_mm, rel=0.02)
    assert error.chamfer_l2_mm == pytest.approx(rms_mm, rel=0.02)
    for threshold_m, f in ((0.001, error.fscore_1mm), (0.002, error.fscore_2mm)):
        inside = np.average(d <= threshold_m, weights=w)   # = precision = recall
        assert f == pytest.approx(inside, abs=0.01)
    assert error.fscore_5mm == 1.0


def test_tilted_plane_normal_consistency_is_the_cosine():
    """Two flat squares at an angle: every nearest point lies on the other flat square, so each
    sample's |cos| is that of the angle between them, whatever its position."""
    angle = np.radians(25.0)
    u = np.linspace(-0.05, 0.05, 11)
    grid = np.stack(np.meshgrid(u, u, indexing="ij"), -1).reshape(-1, 2)
    cells = np.arange(110).reshape(10, 11)[:, :10].ravel()
    faces = np.concatenate([np.column_stack([cells, cells + 11, cells + 1]),
                            np.column_stack([cells + 1, cells + 11, cells + 12])])
    flat = trimesh.Trimesh(np.column_stack([grid, np.zeros(len(grid))]), faces)
    tilted = flat.copy()
    tilted.apply_transform(trimesh.transformations.rotation_matrix(angle, [1, 0, 0]))
    error = surface_error(tilted, flat, n_samples=2000, sharp_edges=np.zeros((0, 2, 3)))
    assert error.normal_consistency == pytest.approx(np.cos(angle), abs=1e-9)
    flipped = flat.copy()
    flipped.invert()                    # unoriented: an inside-out surface keeps its consistency
    assert surface_error(flipped, flat, n_samples=2000, sharp_edges=np.zeros((0, 2, 3))).normal_consistency \
        == pytest.approx(1.0, abs=1e-9)


def test_shape_metrics_edge_cases_and_bad_input():
    m = shape_metrics(np.array([0.0005, 0.003]), np.array([0.01]), np.ones(2), -np.ones(1))
    assert isinstance(m, ShapeMetrics)
    assert m.precision == {"1mm": 0.5, "2mm": 0.5, "5mm": 1.0} and m.recall["5mm"] == 0.0
    assert m.fscore_1mm == 0.0 and m.normal_consistency == 1.0
    assert m.chamfer_l1_mm == pytest.approx((1.75 + 10) / 2)
    with pytest.raises(ValueError, match="non-empty"):
        shape_metrics(np.zeros(0), np.zeros(1), np.zeros(0), np.zeros(1))
    with pytest.raises(ValueError, match="cosine"):
        shape_metrics(np.zeros(2), np.zeros(1), np.zeros(1), np.zeros(1))
    with pytest.raises(ValueError, match=r"\(n, 3\)"):
        point_cloud_metrics(np.zeros((3, 2)), np.zeros((3, 2)), np.zeros((3, 3)), np.ones((3, 3)))
    with pytest.raises(ValueError, match="zero vectors"):
        point_cloud_metrics(np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((3, 3)), np.ones((3, 3)))


# ---------------------------------------------------------------- second implementation
@pytest.fixture(scope="module")
def pcu():
    return pytest.importorskip("point_cloud_utils", reason="point-cloud-utils (test extra) not installed")


def _pcu_samples(pcu, mesh: trimesh.Trimesh, n: int, seed: int):
    v, f = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int32)
    face, bc = pcu.sample_mesh_random(v, f, n, random_seed=seed)
    points = pcu.interpolate_barycentric_coords(f, face, bc, v)
    return points, _face_normals(v, f)[face]


def _face_normals(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def _pcu_mesh_metrics(pcu, reconstruction: trimesh.Trimesh, truth: trimesh.Trimesh, n: int) -> dict:
    """The ShapeMetrics definitions computed with point-cloud-utils' sampler and point-to-mesh query."""
    out = {}
    directional = []
    for source, target, seed in ((reconstruction, truth, 11), (truth, reconstruction, 12)):
        points, normals = _pcu_samples(pcu, source, n, seed)
        tv, tf = np.asarray(target.vertices, np.float64), np.asarray(target.faces, np.int32)
        d, face, _ = pcu.closest_points_on_mesh(points, tv, tf)
        directional.append((d, np.abs(np.einsum("nd,nd->n", normals, _face_normals(tv, tf)[face]))))
    (d_r, c_r), (d_t, c_t) = directional
    out["chamfer_l1_mm"] = 1e3 * (d_r.mean() + d_t.mean()) / 2
    out["chamfer_l2_mm"] = 1e3 * np.sqrt((np.mean(d_r ** 2) + np.mean(d_t ** 2)) / 2)
    for t in (1, 2, 5):
        p, r = np.mean(d_r <= t * 1e-3), np.mean(d_t <= t * 1e-3)
        out[f"fscore_{t}mm"] = 2 * p * r / (p + r) if p + r else 0.0
    out["normal_consistency"] = (c_r.mean() + c_t.mean()) / 2
    return out


def test_surface_error_agrees_with_point_cloud_utils_on_a_deformed_banana(pcu):
    """A banana grown 3 % about its centroid and shifted 1 mm: distances spread over 0-5 mm, so
    every F-score is strictly between 0 and 1. Both sides sample independently (this package 20 000
    per direction, point-cloud-utils 100 000), so they agree up to sampling error: F-scores to 0.015
    (about 4 standard errors), Chamfer to 2 %, normal consistency to 0.005."""
    truth = objects.load("banana").mesh
    deformed = truth.copy()
    deformed.apply_transform(trimesh.transformations.scale_matrix(1.03, truth.centroid))
    deformed.apply_translation([0.001, 0.0, 0.0])
    ours = surface_error(deformed, truth, n_samples=20000, sharp_edges=np.zeros((0, 2, 3)))
    theirs = _pcu_mesh_metrics(pcu, deformed, truth, 100000)
    assert 0.05 < ours.fscore_1mm < ours.fscore_2mm < 0.99   # the comparison covers the mid range
    for key in ("chamfer_l1_mm", "chamfer_l2_mm"):
        assert getattr(ours, key) == pytest.approx(theirs[key], rel=0.02), key
    for key in ("fscore_1mm", "fscore_2mm", "fscore_5mm"):
        assert getattr(ours, key) == pytest.approx(theirs[key], abs=0.015), key
    assert ours.normal_consistency == pytest.approx(theirs["normal_consistency"], abs=0.005)


def test_point_cloud_metrics_match_point_cloud_utils_exactly(pcu):
    """Same two clouds, nearest-sample distances: the k-d trees must agree to rounding."""
    truth = objects.load("cylinder").mesh
    moved = truth.copy()
    moved.apply_translation([0.0015, -0.001, 0.0005])
    rp, rn = _pcu_samples(pcu, moved, 6000, 3)
    tp, tn = _pcu_samples(pcu, truth, 5000, 4)
    ours = point_cloud_metrics(rp, rn, tp, tn)
    # point-cloud-utils' chamfer_distance is the sum convention: mean(d_R) + mean(d_T).
    assert 2 * ours.chamfer_l1_mm == pytest.approx(1e3 * pcu.chamfer_distance(rp, tp), rel=1e-9)
    d_r, i_r = pcu.k_nearest_neighbors(rp, tp, k=1)
    d_t, i_t = pcu.k_nearest_neighbors(tp, rp, k=1)
    d_r, d_t, i_r, i_t = (np.ravel(x) for x in (d_r, d_t, i_r, i_t))
    assert ours.chamfer_l2_mm == pytest.approx(1e3 * np.sqrt((np.mean(d_r ** 2) + np.mean(d_t ** 2)) / 2), rel=1e-9)
    assert ours.precision["2mm"] == np.mean(d_r <= 0.002) and ours.recall["2mm"] == np.mean(d_t <= 0.002)
    unit = lambda n: n / np.linalg.norm(n, axis=1, keepdims=True)  # noqa: E731
    nc = (np.abs(np.sum(unit(rn) * unit(tn)[i_r], 1)).mean() + np.abs(np.sum(unit(tn) * unit(rn)[i_t], 1)).mean()) / 2
    assert ours.normal_consistency == pytest.approx(nc, abs=1e-12)
    assert ours.n_reconstruction_samples == 6000 and ours.n_truth_samples == 5000
