"""Surface error and contact coverage against closed forms."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy.integrate import quad

import objects
from objects.boxes import box_mesh
from objects.revolved import sphere_mesh
from objects.sampling import sample_surface
from reconstruction.metrics import contact_coverage, surface_error

RADIUS_M = 0.05
MESH_TOLERANCE_MM = 0.1  # chord error of the test spheres (objects' promise, tested there)
BOX_M = np.array([0.10, 0.07, 0.05])


@pytest.fixture(scope="module")
def sphere():
    return sphere_mesh(RADIUS_M, step_m=0.004)


def box(size_m, centre_m=(0.0, 0.0, 0.0)) -> trimesh.Trimesh:
    mesh = box_mesh(np.asarray(size_m, float), max_spacing_m=0.01)
    mesh.apply_translation(centre_m)
    return mesh


def test_scaled_sphere_differs_by_the_radius_difference():
    """Scaling by (r + d) / r moves every facet parallel to itself by d h / r (h: the facet plane's
    distance from the centre), so the position RMSE is d times the area-weighted RMS of h / r."""
    delta_m = 0.003
    truth = trimesh.creation.icosphere(subdivisions=4, radius=RADIUS_M)
    grown = truth.copy()
    grown.apply_scale((RADIUS_M + delta_m) / RADIUS_M)
    error = surface_error(grown, truth)

    plane_distance = np.abs(np.einsum("fd,fd->f", truth.face_normals, truth.vertices[truth.faces[:, 0]]))
    area = truth.area_faces
    expected_mm = delta_m * np.sqrt(np.sum(area * (plane_distance / RADIUS_M) ** 2) / area.sum()) * 1e3
    assert expected_mm == pytest.approx(delta_m * 1e3, rel=0.002)
    for value in (error.reconstruction_to_truth_position_rmse_mm, error.truth_to_reconstruction_position_rmse_mm,
                  error.position_rmse_mm):
        assert value == pytest.approx(expected_mm, abs=1e-3)
    assert error.hausdorff_mm == pytest.approx(delta_m * 1e3, abs=0.01)
    # Normals agree except for samples near a facet edge whose closest point is on the
    # neighbouring facet, tilted by the dihedral angle (about 4 degrees here).
    assert error.normal_rmse_deg < 1.0
    assert error.edge_rmse_mm is None and error.n_samples == 20000


def facet_normal_rms_deg(mesh: trimesh.Trimesh, n: int = 100000) -> float:
    """RMS angle between a sphere mesh's facet normals and the true radial normals (area samples)."""
    points, faces = sample_surface(mesh, n, np.random.default_rng(7))
    radial = points / np.linalg.norm(points, axis=1, keepdims=True)
    normals = mesh.face_normals[faces]
    angle = np.arctan2(np.linalg.norm(np.cross(normals, radial), axis=1), np.einsum("nd,nd->n", normals, radial))
    return float(np.degrees(np.sqrt(np.mean(angle**2))))


def test_shifted_sphere_matches_the_closed_form():
    """Sphere moved by t: a point r u + t e lies |r u + t e| - r from the original sphere; with
    s = u . e uniform on [-1, 1] (Archimedes) the mean square is t^2 / 3. The true normals differ by
    atan2(t sqrt(1 - s^2), r + t s), mean square integrated numerically; each mesh's facets add
    their own independent tilt f (measured against the radial direction): total^2 = true^2 + 2 f^2."""
    shift_m = 0.005
    truth = trimesh.creation.icosphere(subdivisions=4, radius=RADIUS_M)
    moved = truth.copy()
    moved.apply_translation([shift_m, 0.0, 0.0])
    error = surface_error(moved, truth)

    expected_mm = shift_m / np.sqrt(3) * 1e3
    assert error.reconstruction_to_truth_position_rmse_mm == pytest.approx(expected_mm, abs=MESH_TOLERANCE_MM)
    assert error.truth_to_reconstruction_position_rmse_mm == pytest.approx(expected_mm, abs=MESH_TOLERANCE_MM)
    assert error.hausdorff_mm == pytest.approx(shift_m * 1e3, abs=MESH_TOLERANCE_MM)

    def angle(s):
        return np.arctan2(shift_m * np.sqrt(1 - s * s), RADIUS_M + shift_m * s)
    true_deg = np.degrees(np.sqrt(quad(lambda s: angle(s) ** 2, -1, 1)[0] / 2))
    expected_deg = np.hypot(true_deg, np.sqrt(2) * facet_normal_rms_deg(truth))
    assert error.reconstruction_to_truth_normal_rmse_deg == pytest.approx(expected_deg, abs=0.05)
    assert error.truth_to_reconstruction_normal_rmse_deg == pytest.approx(expected_deg, abs=0.05)


def test_box_with_one_face_pushed_out_matches_the_closed_form():
    """Top face raised by d. Reconstruction -> truth: the raised top is d away, the new side strips
    (height d) are h away at height h, the rest coincides. Truth -> reconstruction: a point of the
    old top is min(d, distance to the nearest side) inside; the rest coincides."""
    a, b, c = BOX_M
    d = 0.01
    truth = box(BOX_M)
    pushed = box([a, b, c + d], [0.0, 0.0, d / 2])
    error = surface_error(pushed, truth, n_samples=40000)

    area_pushed = 2 * a * b + 2 * (a + b) * (c + d)
    forward = np.sqrt((a * b * d**2 + 2 * (a + b) * d**3 / 3) / area_pushed)
    half_a, half_b = a / 2, b / 2  # one quadrant of the old top: integral of min(d, u, v)^2
    quadrant = (d**2 * (half_a - d) * (half_b - d) + d**3 * (half_a + half_b - 2 * d) / 3 + d**4 / 6)
    area_truth = 2 * a * b + 2 * (a + b) * c
    backward = np.sqrt(4 * quadrant / area_truth)
    # Sampling scatter (standard deviation over seeds) is about 0.6 % of the backward value.
    assert error.reconstruction_to_truth_position_rmse_mm == pytest.approx(forward * 1e3, rel=0.025)
    assert error.truth_to_reconstruction_position_rmse_mm == pytest.approx(backward * 1e3, rel=0.025)

    # Old-top points near a side find their closest point on that side: 90 degrees; elsewhere 0.
    border = a * b - (a - 2 * d) * (b - 2 * d)
    assert error.truth_to_reconstruction_normal_rmse_deg == pytest.approx(90 * np.sqrt(border / area_truth), rel=0.03)
    strips = 2 * (a + b) * d  # closest point on the old top edge: 0 or 90 degrees
    assert error.reconstruction_to_truth_normal_rmse_deg <= 90 * np.sqrt(strips / area_pushed) * 1.05
    assert error.edge_rmse_mm < 1e-9  # every old edge still lies on the pushed box's surface


def test_grown_box_is_the_growth_away_everywhere_on_the_truth():
    """Box grown by g on every side: each truth point, edges included, is g inside. Each grown
    face of sides A x B is g above the old plane plus the overhang e: mean of g^2 + ex^2 + ey^2
    with E[ex^2] = 2 g^3 / (3 A)."""
    g = 0.004
    grown_size = BOX_M + 2 * g
    error = surface_error(box(grown_size), box(BOX_M))
    assert error.truth_to_reconstruction_position_rmse_mm == pytest.approx(g * 1e3, rel=1e-9)
    assert error.edge_rmse_mm == pytest.approx(g * 1e3, rel=1e-9)

    faces = [(grown_size[i], grown_size[j]) for i, j in ((0, 1), (1, 2), (0, 2))]
    mean_square = sum(2 * A * B * (g**2 + 2 * g**3 / (3 * A) + 2 * g**3 / (3 * B)) for A, B in faces)
    area = sum(2 * A * B for A, B in faces)
    assert error.reconstruction_to_truth_position_rmse_mm == pytest.approx(np.sqrt(mean_square / area) * 1e3, rel=0.01)


def test_edge_error_of_a_box_against_a_sphere_matches_the_line_integral(sphere):
    """Distance from a box edge point q to the sphere is | |q| - r |; integrate along the edges."""
    half = BOX_M / 2
    total_square, total_length = 0.0, 0.0
    for axis in range(3):
        others = [i for i in range(3) if i != axis]
        offset_sq = half[others[0]] ** 2 + half[others[1]] ** 2
        square = quad(lambda x: (np.sqrt(x * x + offset_sq) - RADIUS_M) ** 2, -half[axis], half[axis])[0]
        total_square += 4 * square
        total_length += 4 * 2 * half[axis]
    expected_mm = np.sqrt(total_square / total_length) * 1e3

    error = surface_error(sphere, box(BOX_M), n_samples=2000, n_edge_samples=20000)
    assert error.edge_rmse_mm == pytest.approx(expected_mm, rel=0.015)


def test_sharp_edges_default_to_the_truths_own(sphere):
    truth = box(BOX_M)
    detected = surface_error(sphere, truth, n_samples=2000)
    given = surface_error(sphere, truth, n_samples=2000, sharp_edges=objects.sharp_edges(truth))
    assert detected == given and detected.edge_rmse_mm > 0
    skipped = surface_error(sphere, truth, n_samples=2000, sharp_edges=np.zeros((0, 2, 3)))
    assert skipped.edge_rmse_mm is None
    assert surface_error(truth, sphere, n_samples=2000).edge_rmse_mm is None  # smooth truth


def test_identical_and_inverted_meshes():
    truth = box(BOX_M)
    same = surface_error(truth.copy(), truth, n_samples=5000)
    assert same.position_rmse_mm < 1e-9 and same.hausdorff_mm < 1e-9
    assert same.normal_rmse_deg < 1e-6 and same.edge_rmse_mm < 1e-9
    inverted = truth.copy()
    inverted.invert()
    flipped = surface_error(inverted, truth, n_samples=5000)
    assert flipped.position_rmse_mm < 1e-9
    assert flipped.reconstruction_to_truth_normal_rmse_deg == pytest.approx(180.0, abs=1e-6)
    assert flipped.truth_to_reconstruction_normal_rmse_deg == pytest.approx(180.0, abs=1e-6)


def test_same_seed_same_numbers_other_seed_close(sphere):
    moved = sphere.copy()
    moved.apply_translation([0.002, 0.0, 0.0])
    first, again = surface_error(moved, sphere, n_samples=5000), surface_error(moved, sphere, n_samples=5000)
    assert first == again
    other = surface_error(moved, sphere, n_samples=5000, seed=1)
    assert other.position_rmse_mm != first.position_rmse_mm
    assert other.position_rmse_mm == pytest.approx(first.position_rmse_mm, rel=0.05)


def test_surface_error_rejects_bad_input(sphere):
    with pytest.raises(ValueError, match="reconstruction mesh is empty"):
        surface_error(trimesh.Trimesh(), sphere)
    with pytest.raises(ValueError, match="truth must be a trimesh.Trimesh, got ndarray"):
        surface_error(sphere, np.zeros((10, 3)))
    nan_mesh = sphere.copy()
    nan_mesh.vertices[0] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        surface_error(nan_mesh, sphere)
    flat = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [2, 0, 0]], [[0, 1, 2]], process=False)
    with pytest.raises(ValueError, match="zero surface area"):
        surface_error(flat, sphere)
    for bad in (0, -5, 2.5, True):
        with pytest.raises(ValueError, match="n_samples must be a positive integer"):
            surface_error(sphere, sphere, n_samples=bad)
    with pytest.raises(ValueError, match=r"sharp_edges must have shape \(k, 2, 3\)"):
        surface_error(sphere, sphere, sharp_edges=np.zeros((4, 3)))


# --- coverage ----------------------------------------------------------------------------------

def test_coverage_of_polar_contacts_is_the_cap_area(sphere):
    """Sphere points within chord rho of a pole form a cap of height rho^2 / (2 r), area pi rho^2:
    the fraction rho^2 / (4 r^2)."""
    rho = 0.02
    north = np.array([[0.0, 0.0, RADIUS_M]])
    expected = rho**2 / (4 * RADIUS_M**2)
    assert contact_coverage(north, sphere, rho) == pytest.approx(expected, abs=0.005)
    both = np.vstack([north, -north])
    assert contact_coverage(both, sphere, rho, n_samples=40000, seed=3) == pytest.approx(2 * expected, abs=0.006)


def test_coverage_limits(sphere):
    centre = np.zeros((1, 3))
    assert contact_coverage(centre, sphere, 0.9 * RADIUS_M) == 0.0
    assert contact_coverage(centre, sphere, 1.01 * RADIUS_M) == 1.0
    assert contact_coverage(np.zeros((0, 3)), sphere, 0.01) == 0.0


def test_coverage_rejects_bad_input(sphere):
    with pytest.raises(ValueError, match=r"contacts_m must have shape \(n, 3\)"):
        contact_coverage(np.zeros(3), sphere, 0.01)
    with pytest.raises(ValueError, match="radius_m must be a positive"):
        contact_coverage(np.zeros((1, 3)), sphere, 0.0)
    with pytest.raises(ValueError, match="non-finite"):
        contact_coverage(np.full((1, 3), np.nan), sphere, 0.01)
    with pytest.raises(ValueError, match="truth mesh is empty"):
        contact_coverage(np.zeros((1, 3)), trimesh.Trimesh(), 0.01)



def test_zero_area_faces_change_nothing():
    truth = trimesh.creation.icosphere(subdivisions=3, radius=RADIUS_M)
    moved = truth.copy()
    moved.apply_translation([0.002, 0.0, 0.0])
    padded = trimesh.Trimesh(moved.vertices, np.vstack([moved.faces, [[0, 1, 1], [2, 2, 2]]]), process=False)
    assert surface_error(padded, truth, n_samples=3000) == surface_error(moved, truth, n_samples=3000)


def test_the_rmse_standard_error_is_the_scatter_of_repeated_samplings():
    # independent answer: draw the two directions' distances many times from fixed, skewed
    # distributions and measure how much the symmetric RMSE scatters from draw to draw
    from reconstruction.metrics import symmetric_rmse_standard_error

    rng = np.random.default_rng(5)
    n, repeats = 2000, 600
    forward = rng.exponential(1e-3, size=(repeats, n))        # a tail of phantom surface
    backward = np.abs(rng.normal(0.0, 0.4e-3, size=(repeats, n)))
    rmse = 0.5 * (np.sqrt(np.mean(forward ** 2, axis=1)) + np.sqrt(np.mean(backward ** 2, axis=1)))
    predicted = [symmetric_rmse_standard_error(f, b) for f, b in zip(forward[:50], backward[:50])]
    assert np.median(predicted) == pytest.approx(np.std(rmse, ddof=1), rel=0.15)
    assert symmetric_rmse_standard_error(np.full(10, 2e-3), np.full(10, 1e-3)) < 1e-15  # no scatter, no error
    with pytest.raises(ValueError, match="two distance samples"):
        symmetric_rmse_standard_error(np.array([1e-3]), np.ones(5))
