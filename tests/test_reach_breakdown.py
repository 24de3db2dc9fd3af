"""The out-of-reach breakdown (explorer.coverage) against shapes whose answer is known in closed form."""
import numpy as np
import pytest
import trimesh

from explorer.coverage import REACH_CLASSES, SurfaceDistance, ToolEnvelope, reach_breakdown

SAMPLES = 600
# Two standard errors of a fraction near 0.1 from SAMPLES samples, plus a voxel's worth of boundary.
TOLERANCE = 0.03


def _cup_with_bore(outer_r, height, bore_r, bore_depth):
    """A solid cylinder (base at z = 0) with a coaxial blind bore from the top; its inside area share."""
    outer = trimesh.creation.cylinder(outer_r, height, sections=96)
    outer.apply_translation((0, 0, height / 2))
    bore = trimesh.creation.cylinder(bore_r, bore_depth + 0.01, sections=96)
    bore.apply_translation((0, 0, height - bore_depth + (bore_depth + 0.01) / 2))
    cup = outer.difference(bore)
    assert cup.is_watertight
    inside = 2 * np.pi * bore_r * bore_depth + np.pi * bore_r**2
    return cup, inside / cup.area


class NoPlan:
    """A planner that never finds a plan (the arm reaches nothing)."""

    def plan(self, touch, seed_q=None, tilted=True):
        return None


def test_an_inside_narrower_than_the_pad_is_the_pad_does_not_fit_share():
    cup, inside_share = _cup_with_bore(0.03, 0.04, 0.006, 0.02)   # 12 mm bore, 18 mm pad
    b = reach_breakdown(cup, np.zeros((0, 3)), None, n_samples=SAMPLES, seed=1)
    assert 0.04 < inside_share < 0.09
    assert b.pad_does_not_fit == pytest.approx(inside_share, abs=TOLERANCE)
    assert b.arm_cannot_reach == 0.0 and b.touched == 0.0
    assert b.reachable == pytest.approx(1.0 - b.pad_does_not_fit)


def test_an_inside_wider_than_the_pad_fits():
    cup, inside_share = _cup_with_bore(0.04, 0.03, 0.03, 0.01)   # 60 mm wide, 10 mm deep: a dish
    b = reach_breakdown(cup, np.zeros((0, 3)), None, n_samples=SAMPLES, seed=2)
    assert inside_share > 0.2
    # only the crease where the floor meets the wall (pad half width + hover from the wall) is left
    crease = (2 * np.pi * 0.03 * 0.0105 + np.pi * (0.03**2 - 0.0195**2)) / cup.area
    assert b.pad_does_not_fit < crease + TOLERANCE


def test_a_convex_body_fits_everywhere_and_the_arm_classes_follow_the_planner():
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=0.03)
    free = reach_breakdown(sphere, np.zeros((0, 3)), None, n_samples=200)
    assert free.pad_does_not_fit == 0.0 and free.reachable_untouched == 1.0
    blocked = reach_breakdown(sphere, np.zeros((0, 3)), NoPlan(), n_samples=200)
    assert blocked.arm_cannot_reach == 1.0 and blocked.reachable == 0.0
    assert np.isnan(blocked.reachable_coverage)


def test_touched_is_the_spherical_cap_within_the_radius_of_a_contact():
    r, rho = 0.03, 0.02
    sphere = trimesh.creation.icosphere(subdivisions=5, radius=r)
    b = reach_breakdown(sphere, np.array([[0.0, 0.0, r]]), None, radius_m=rho, n_samples=SAMPLES, seed=3)
    cap_share = rho**2 / (4 * r**2)          # cap height rho^2 / 2r over the sphere's 4 pi r^2
    assert b.touched == pytest.approx(cap_share, abs=TOLERANCE)
    assert sum(b.as_dict()[name] for name in REACH_CLASSES) == pytest.approx(1.0)
    assert b.reachable_coverage == pytest.approx(b.touched)


def test_surface_distance_is_the_closed_form_distance_to_a_box_and_the_field_within_its_bound():
    half = np.array([0.04, 0.03, 0.02])
    box = trimesh.creation.box(extents=2 * half)
    distance = SurfaceDistance(box)
    points = np.random.default_rng(0).uniform(-0.06, 0.06, (2000, 3))
    q = np.abs(points) - half
    exact = np.abs(np.linalg.norm(np.maximum(q, 0.0), axis=1) + np.minimum(q.max(axis=1), 0.0))
    np.testing.assert_allclose(distance.exact(points), exact, atol=1e-12)
    field = distance.field(points)
    inside = np.isfinite(field)
    assert inside.sum() > 200
    assert np.all(np.abs(field[inside] - exact[inside]) <= distance.bound_m)
    assert np.all(exact[~inside] > 1.6 * distance.pitch_m)  # what any_within relies on
    # any_within is the exact answer, point cloud by point cloud, near the threshold and away from it
    for clearance in (0.0012, 0.003, 0.01):
        for cloud in np.array_split(np.arange(len(points)), 200):
            assert distance.any_within(points[cloud], clearance) == bool(np.min(exact[cloud]) < clearance)


def test_approach_directions_are_head_on_then_tilted():
    tool = ToolEnvelope()
    normal = np.array([0.0, 0.0, 1.0])
    dirs = tool.approach_directions(normal)
    np.testing.assert_allclose(dirs[0], -normal)
    np.testing.assert_allclose(np.linalg.norm(dirs, axis=1), 1.0)
    angles = np.degrees(np.arccos(np.clip(dirs @ -normal, -1, 1)))
    assert len(dirs) == 1 + tool.azimuths * (len(tool.tilts_rad) - 1)
    assert np.all(np.diff(angles) > -1e-9)


def test_coverage_ceiling_is_contacts_times_a_cap_on_a_sphere_and_caps_at_one():
    from explorer.coverage import coverage_ceiling

    sphere = trimesh.creation.icosphere(subdivisions=5, radius=0.1)
    cap_share = np.pi * 0.01**2 / (4 * np.pi * 0.1**2)   # a 1 cm ball cuts a cap of area pi r^2
    ceiling = coverage_ceiling(sphere, 10)
    assert 10 * cap_share * 0.97 < ceiling < 10 * cap_share * 1.25   # the largest of noisy counts: upwards
    assert coverage_ceiling(sphere, 10_000) == 1.0
    assert coverage_ceiling(sphere, 0) == 0.0


def test_placed_coverage_covers_a_cap_per_contact_and_beats_a_random_placement():
    from scipy.spatial import cKDTree

    from explorer.coverage import coverage_ceiling, placed_coverage

    sphere = trimesh.creation.icosphere(subdivisions=5, radius=0.1)
    cap_share = np.pi * 0.01**2 / (4 * np.pi * 0.1**2)   # closed form: a 1 cm ball cuts a cap of area pi r^2
    # ten caps far apart: a count of about 1,000 fresh samples, binomial noise about 3 %
    assert 10 * cap_share * 0.88 < placed_coverage(sphere, 10, per_disc=400) < 10 * cap_share * 1.12
    assert placed_coverage(sphere, 0) == 0.0
    assert placed_coverage(sphere, 10_000) > 0.97   # every sample of the greedy covered; fresh ones in its gaps may not be

    # A random placement of as many contacts, scored the same way, covers less; and no placement beats
    # the ceiling (beyond the two samplings' own noise).
    box = trimesh.creation.box(extents=(0.12, 0.08, 0.03))
    samples, _ = trimesh.sample.sample_surface_even(box, 20_000, seed=3)
    rng = np.random.default_rng(4)
    for n in (5, 20, 60):
        placed = placed_coverage(box, n)
        contacts = samples[rng.choice(len(samples), n, replace=False)]
        random_coverage = np.mean(cKDTree(contacts).query(samples)[0] <= 0.01)
        assert random_coverage < placed <= 1.05 * coverage_ceiling(box, n)
    assert placed_coverage(box, 20) < placed_coverage(box, 60)
