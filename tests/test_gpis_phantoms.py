"""Phantom surface and monotonicity of the default GPIS on cheap closed-form cases (issue 10).

Phantom lobes are 0-level surface where no contact supports it. On a convex object every true
surface point lies behind the tangent plane of every contact, so with noise-free contacts any mesh
vertex clearly in front of one of those planes is phantom surface, whatever the reconstruction does
with the unobserved part.
"""

import numpy as np
import pytest
import trimesh

from reconstruction.gpis import GPIS
from reconstruction.metrics import surface_error
from reconstruction.synthetic_contacts import ContactNoise, sample_contacts

RADIUS = 0.05
BOUNDS = ((-0.07, -0.07, -0.07), (0.07, 0.07, 0.07))
RESOLUTION = 40
#: Marching cubes places vertices on grid edges by linear interpolation; on a smooth field whose
#: curvature radius is the sphere's this is within (edge length)^2 / (8 radius) of the 0-level set.
VOXEL = (BOUNDS[1][0] - BOUNDS[0][0]) / (RESOLUTION - 1)
MESHING_TOLERANCE = VOXEL**2 / (8 * RADIUS)


@pytest.fixture(scope="module")
def sphere():
    return trimesh.creation.icosphere(subdivisions=5, radius=RADIUS)


@pytest.mark.parametrize("seed", [0, 1])
def test_contacts_on_half_a_sphere_grow_no_surface_outside_it(sphere, seed):
    points, normals, _, _ = sample_contacts(sphere, 300, noise=ContactNoise.off(), seed=seed)
    upper = points[:, 2] > 0
    points, normals = points[upper][:100], normals[upper][:100]
    mesh = GPIS(bounds=BOUNDS).fit(points, normals).mesh(resolution=RESOLUTION)

    # In front of a contact's tangent plane = outside the sphere (convexity); the icosphere's facets
    # sit up to RADIUS * (1 - cos(edge / 2R)) inside the ideal sphere.
    facet_sag = RADIUS - np.min(np.linalg.norm(sphere.triangles_center, axis=1))
    height = np.einsum("vcj,cj->vc", mesh.vertices[:, None, :] - points[None], normals).max(1)
    assert height.max() < MESHING_TOLERANCE + facet_sag + 0.2e-3
    # The unobserved lower half closes without lobes: nothing beyond the sphere by more than the
    # p99 target of issue 10 (3 mm), and the surface does close below the equator.
    radius = np.linalg.norm(mesh.vertices, axis=1)
    assert radius.max() < RADIUS + 3e-3
    assert mesh.vertices[:, 2].min() < -0.5 * RADIUS


def test_error_does_not_grow_with_more_contacts_on_an_ellipsoid():
    truth = trimesh.creation.icosphere(subdivisions=4, radius=1.0)
    truth.apply_scale([0.06, 0.04, 0.03])
    points, normals, _, _ = sample_contacts(truth, 200, seed=3)
    errors = []
    for n in (50, 100, 200):  # nested draws: each set contains the previous one
        gp = GPIS(bounds=((-0.08, -0.06, -0.05), (0.08, 0.06, 0.05))).fit(points[:n], normals[:n])
        errors.append(surface_error(gp.mesh(resolution=40), truth, n_samples=4000, seed=0).position_rmse_mm)
    # Sampling the metric with 4000 points per side changes it by a few per cent between meshes.
    assert errors[1] <= 1.05 * errors[0] and errors[2] <= 1.05 * errors[1], errors
    assert errors[2] < 0.75 * errors[0], errors


@pytest.fixture(scope="module")
def half_sphere_gpis(sphere):
    points, normals, _, _ = sample_contacts(sphere, 300, seed=4)  # default sensor noise
    upper = points[:, 2] > 0
    return GPIS(bounds=BOUNDS).fit(points[upper][:100], normals[upper][:100])


def test_confident_surface_cuts_the_unobserved_half_and_keeps_every_touched_place(half_sphere_gpis):
    from scipy.spatial import cKDTree

    from reconstruction.confidence import DEFAULT_KEEP_NEAR_CONTACT_M

    gp = half_sphere_gpis
    full = gp.mesh(resolution=RESOLUTION)
    confident = gp.mesh(resolution=RESOLUTION, max_std_m=2e-3)
    # The closed mesh reaches the bottom; the unobserved half is uncertain and cut (its nearest
    # contacts are 5 cm away at the pole).
    assert full.vertices[:, 2].min() < -0.8 * RADIUS
    assert confident.vertices[:, 2].min() > -0.5 * RADIUS
    assert len(confident.faces) < len(full.faces)
    # Every face of the closed mesh near a contact is still there (same vertices, same faces).
    near = cKDTree(gp.contact_points).query(full.vertices)[0] <= DEFAULT_KEEP_NEAR_CONTACT_M
    kept = {tuple(np.round(v, 9)) for v in confident.vertices}
    assert all(tuple(np.round(v, 9)) in kept for v in full.vertices[near])


def test_confident_surface_uses_the_posterior_std(half_sphere_gpis):
    from reconstruction.confidence import vertex_std

    gp = half_sphere_gpis
    x = np.array([[0.0, 0.0, -RADIUS], [0.0, 0.0, RADIUS + 0.01], [0.03, 0.0, 0.02]])
    std = vertex_std(gp, x, keep_near_contact_m=0.0)
    assert np.allclose(std, np.sqrt(gp.variance(x)))
    assert std[0] > 2e-3  # the unobserved pole is uncertain
    # A bound no vertex exceeds keeps the whole mesh.
    full = gp.mesh(resolution=24)
    assert len(gp.mesh(resolution=24, max_std_m=10.0).faces) == len(full.faces)


@pytest.mark.parametrize("kwargs, message", [
    (dict(max_std_m=0.0), "max_std_m must be a positive length"),
    (dict(max_std_m=float("nan")), "max_std_m must be a positive length"),
    (dict(keep_near_contact_m=-1.0), "keep_near_contact_m must be a length >= 0"),
])
def test_confident_surface_refuses_bad_bounds(half_sphere_gpis, kwargs, message):
    from reconstruction.confidence import confident_surface

    mesh = half_sphere_gpis.mesh(resolution=16)
    with pytest.raises(ValueError, match=message):
        confident_surface(half_sphere_gpis, mesh, **kwargs)


def test_hull_distance_is_the_distance_in_front_of_a_facet():
    from reconstruction.confidence import hull_distance

    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float) * 0.1
    x = np.array([[0.05, 0.05, 0.13], [0.05, 0.05, 0.05], [-0.02, 0.05, 0.05]])
    assert np.allclose(hull_distance(corners, x), [0.03, -0.05, 0.02])
    flat = corners[corners[:, 2] == 0]  # spans no volume
    assert np.all(np.isinf(hull_distance(flat, x)))


def test_sparse_flat_faces_are_uncertain_but_kept_inside_the_contact_hull():
    box = trimesh.creation.box(extents=(0.10, 0.08, 0.04))
    points, normals, _, _ = sample_contacts(box, 120, seed=2)
    gp = GPIS(bounds=((-0.07, -0.06, -0.04), (0.07, 0.06, 0.04))).fit(points, normals)
    from reconstruction.confidence import confident_surface

    full = gp.mesh(resolution=32)
    by_std_only = confident_surface(gp, full, max_std_m=1e-3, hull_margin_m=None)
    with_hull = gp.mesh(resolution=32, max_std_m=1e-3)
    # 120 contacts on 0.031 m^2 leave the faces uncertain between them: a strict bound on the std
    # alone cuts most of them (a third is left) ...
    assert by_std_only.area < 0.5 * full.area
    # ... the hull keeps the surface that spans the contacts (near edges it is outside the hull).
    assert with_hull.area > 0.8 * full.area


def test_the_mesh_is_cut_at_a_wedges_whole_faces_where_the_smooth_mean_rounds_past_its_corners():
    # a wedge (right-triangle profile, 140 x 50 mm, 60 mm wide), 200 contacts with the default
    # noise: the smooth mean rounds lobes out past the corners between its flat faces; cut at the
    # faces' planes, no vertex stands in front of one beyond its allowance (to the meshing's
    # resolution), and what the cut removed was off the truth
    from objects.proximity import MeshProximity
    from reconstruction.face_planes import whole_face_planes

    wedge = trimesh.Trimesh([(x, y, z) for x, z in ((0, 0), (0.14, 0), (0.14, 0.002), (0, 0.05))
                             for y in (0.0, 0.06)]).convex_hull
    wedge.apply_translation(-wedge.bounds.mean(axis=0))
    points, normals, _, _ = sample_contacts(wedge, 200, seed=5)
    bounds = (wedge.bounds[0] - 0.03, wedge.bounds[1] + 0.03)
    gp = GPIS(bounds=bounds).fit(points, normals)
    faces = whole_face_planes(points, normals)
    assert len(faces) >= 4
    uncut, cut = gp.mesh(resolution=64, cut_at_faces=False), gp.mesh(resolution=64)
    voxel = float(np.max(bounds[1] - bounds[0])) / 63
    removed = faces.clearance(uncut.vertices) < -1e-3
    assert removed.sum() > 20  # the lobes the cut is for
    assert faces.clearance(cut.vertices).min() > -0.1 * voxel
    # independent of the faces: what the cut removed stood more than a millimetre off the truth
    assert np.all(MeshProximity(wedge).query(uncut.vertices[removed])[1] > 1e-3)
    assert surface_error(cut, wedge, 4000).position_rmse_mm < surface_error(uncut, wedge, 4000).position_rmse_mm
