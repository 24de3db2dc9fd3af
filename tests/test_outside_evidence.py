"""Outside evidence beyond the contacts' convex hull (reconstruction/outside_evidence.py, issue 10)."""

import copy

import numpy as np
import pytest
import trimesh
from scipy.spatial import ConvexHull

from reconstruction.gpis import GPIS
from reconstruction.outside_evidence import GRID_CELLS, GRID_SPACING_M, add_outside_evidence, free_space_candidates
from reconstruction.synthetic_contacts import ContactNoise, sample_contacts

CUBE = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float) * 0.1
BOX = ((-0.05, -0.05, -0.05), (0.15, 0.15, 0.15))


def test_candidates_are_the_points_beyond_the_facet_margin():
    fraction = 0.5
    points, distance = free_space_candidates(CUBE, BOX, facet_fraction=fraction, min_margin_m=0.0,
                                             max_open_angle_rad=None)
    # Independently: the cube's hull facets are half faces, right triangles with legs 0.1 m, whose
    # circumradius (largest vertex distance from the centroid) is sqrt(5) / 3 * 0.1 m; the distance
    # outside the cube is the largest excess over its six face planes.
    margin = fraction * np.sqrt(5.0) / 3.0 * 0.1
    spacing = max(GRID_SPACING_M, 0.2 / GRID_CELLS)
    axes = [np.arange(a + spacing / 2, b, spacing) for a, b in zip(*BOX)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    excess = np.max(np.concatenate([-grid, grid - 0.1], axis=1), axis=1)
    expected = grid[excess > margin]
    assert len(points) == len(expected) > 0
    assert np.allclose(np.sort(points, axis=0), np.sort(expected, axis=0))
    assert np.allclose(distance, np.max(np.concatenate([-points, points - 0.1], axis=1), axis=1))


def test_the_untouched_half_of_a_sphere_is_not_taken_as_free_space():
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=0.05)
    points, _, _, _ = sample_contacts(sphere, 300, noise=ContactNoise.off(), seed=0)
    upper = points[points[:, 2] > 0][:100]
    box = ((-0.07,) * 3, (0.07,) * 3)
    open_any, _ = free_space_candidates(upper, box, max_open_angle_rad=None)
    enclosed, _ = free_space_candidates(upper, box)
    # Without the enclosure test, points of the untouched lower half (inside the true sphere) count
    # as free: the lower half continues beyond the hull's rim. With it, none does, and the free
    # space found above the touched half remains.
    assert np.count_nonzero(np.linalg.norm(open_any, axis=1) < 0.05) > 0
    assert np.count_nonzero(np.linalg.norm(enclosed, axis=1) < 0.05) == 0
    assert np.count_nonzero(enclosed[:, 2] > 0.05) > 0


def test_the_margin_grows_with_the_facet_and_has_a_floor():
    loose, _ = free_space_candidates(CUBE, BOX, facet_fraction=0.5, min_margin_m=0.0, max_open_angle_rad=None)
    tight, _ = free_space_candidates(CUBE, BOX, facet_fraction=0.25, min_margin_m=0.0, max_open_angle_rad=None)
    _, floored = free_space_candidates(CUBE, BOX, facet_fraction=0.0, min_margin_m=0.02, max_open_angle_rad=None)
    assert 0 < len(loose) < len(tight)
    assert floored.min() > 0.02


def test_contacts_spanning_no_volume_give_no_candidates():
    flat = CUBE[CUBE[:, 2] == 0]
    points, distance = free_space_candidates(flat, BOX)
    assert points.shape == (0, 3) and distance.shape == (0,)


@pytest.mark.parametrize("kwargs, message", [
    (dict(facet_fraction=-0.1), "facet_fraction must be a finite number >= 0"),
    (dict(min_margin_m=float("nan")), "min_margin_m must be a length >= 0"),
    (dict(max_open_angle_rad=0.0), "max_open_angle_rad must be None or an angle"),
])
def test_bad_margins_are_refused(kwargs, message):
    with pytest.raises(ValueError, match=message):
        free_space_candidates(CUBE, BOX, **kwargs)


@pytest.fixture(scope="module")
def lid():
    """A generated lid (a thin dish) with 120 contacts: its sparse rims leave phantom lobes."""
    import objects

    truth = objects.load("generated:lid/0").mesh
    points, normals, _, _ = sample_contacts(truth, 120, noise=ContactNoise.off(), seed=0)
    lo, hi = truth.bounds
    pad = 0.2 * np.max(hi - lo)
    return truth, GPIS(bounds=(lo - pad, hi + pad)).fit(points, normals)


def test_mesh_with_outside_evidence_grows_less_surface_beyond_the_contacts_hull(lid):
    from objects.proximity import MeshProximity

    truth, gp = lid
    rows = gp.n_rows
    mean_before = gp.mean(gp.contact_points[:5])
    plain = gp.mesh(resolution=40, outside_evidence=False)
    carved = gp.mesh(resolution=40, outside_evidence=True)
    # The GPIS itself is unchanged by meshing with the evidence.
    assert gp.n_rows == rows
    assert np.array_equal(gp.mean(gp.contact_points[:5]), mean_before)

    hull = ConvexHull(gp.contact_points)

    def beyond(mesh):
        return np.max(mesh.vertices @ hull.equations[:, :3].T + hull.equations[:, 3], axis=1)

    # The plain surface has lobes more than 2 cm beyond the hull; with the evidence the surface
    # beyond 1 cm shrinks, and so does its 99th percentile distance to the truth.
    assert beyond(plain).max() > 0.02
    assert np.count_nonzero(beyond(carved) > 0.01) < 0.5 * np.count_nonzero(beyond(plain) > 0.01)
    proximity = MeshProximity(truth)
    p99 = [np.quantile(proximity.query(m.vertices)[1], 0.99) for m in (plain, carved)]
    assert p99[1] < p99[0]


def test_the_default_mesh_is_the_plain_mean(lid):
    # The evidence is an option: on sparsely touched objects it cuts true surface (BENCHMARKS.md).
    _, gp = lid
    default, plain = gp.mesh(resolution=32), gp.mesh(resolution=32, outside_evidence=False)
    assert np.array_equal(default.vertices, plain.vertices)
    assert not np.array_equal(gp.mesh(resolution=32, outside_evidence=True).vertices, plain.vertices)


def test_evidence_rows_are_values_below_zero_at_free_space(lid):
    _, fitted = lid
    gp = copy.deepcopy(fitted)
    points, _ = free_space_candidates(gp.contact_points, gp.region)
    solid_before = np.count_nonzero(gp.mean(points) > 0)
    added = add_outside_evidence(gp)
    assert solid_before > 0 and added > 0
    assert gp.n_rows == fitted.n_rows + added
    # After the rounds, (almost) none of the free space is still solid.
    assert np.count_nonzero(gp.mean(points) > 0) < 0.1 * solid_before


def test_a_densely_touched_sphere_gets_no_evidence():
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=0.05)
    points, normals, _, _ = sample_contacts(sphere, 200, noise=ContactNoise.off(), seed=1)
    gp = GPIS(bounds=((-0.07,) * 3, (0.07,) * 3)).fit(points, normals)
    # Nothing of the fitted surface is further than the margin outside the contacts' hull, so the
    # mesh is the plain one, face for face.
    assert add_outside_evidence(copy.deepcopy(gp)) == 0
    assert np.array_equal(gp.mesh(resolution=32, outside_evidence=True).faces, gp.mesh(resolution=32).faces)


def test_the_classic_gpis_without_normals_is_meshed_as_before(lid):
    _, with_normals = lid
    gp = GPIS(use_normals=False, bounds=with_normals.bounds).fit(with_normals.contact_points)
    a = gp.mesh(resolution=24, outside_evidence=True)
    b = gp.mesh(resolution=24)
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)


def test_noise_must_be_positive(lid):
    _, gp = lid
    with pytest.raises(ValueError, match="noise_m must be a positive length"):
        add_outside_evidence(gp, noise_m=0.0)
