"""Symmetry found from contacts (reconstruction/symmetry.py, issue 10).

Each case builds a body whose symmetry is known in closed form, moves it to a random pose, samples
contacts on it and checks what ``find_symmetry`` says against the truth.
"""

import copy
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

import objects
from objects.proximity import MeshProximity
from objects.sampling import sample_surface
from reconstruction.gpis import GPIS
from reconstruction.metrics import surface_error
from reconstruction.symmetry import (Symmetry, SymmetrySettings, _feature_of_mirror, _ImageJudge, _fit_axis,
                                     _mirror_offset, _mirrored_profile_residuals, _polish_axis, _polish_planes_axis,
                                     _replaced, _rescue_axis, _turns_accepted, contradicted_images,
                                     disputed_contacts, find_symmetry, profile_misfit, reflection, rotation)
from reconstruction.synthetic_contacts import ContactNoise, sample_contacts


def _posed(mesh, seed):
    """The mesh turned and shifted by a seeded random rigid motion, and that motion (R, t)."""
    rng = np.random.default_rng(seed)
    r = Rotation.random(random_state=seed).as_matrix()
    t = rng.uniform(-0.02, 0.02, 3)
    moved = mesh.copy()
    moved.apply_transform(np.block([[r, t[:, None]], [np.zeros((1, 3)), np.ones((1, 1))]]))
    return moved, r, t


def _vase():
    """A surface of revolution about z (a vase-like profile, 12 cm tall), metres."""
    z = np.linspace(-0.06, 0.06, 25)
    radius = 0.035 + 0.012 * np.sin(z / 0.06 * 2.2)
    profile = np.column_stack([np.r_[0.0, radius, 0.0], np.r_[z[0], z, z[-1]]])
    return trimesh.creation.revolve(profile, sections=96)


def test_transforms_in_closed_form():
    m, t = reflection(np.array([0.0, 0.0, 1.0]), 0.01)
    assert np.allclose(m @ [0.1, 0.2, 0.0] + t, [0.1, 0.2, 0.02])
    r, s = rotation(np.array([0.0, 0.0, 2.0]), np.array([0.1, 0.0, 0.0]), np.pi / 2)
    assert np.allclose(r @ [0.2, 0.0, 0.3] + s, [0.1, 0.1, 0.3])


@pytest.mark.parametrize("seed", [0, 1])
def test_a_surface_of_revolution_in_any_pose(seed):
    vase, r, t = _posed(_vase(), seed)
    points, normals, _, _ = sample_contacts(vase, 150, noise=ContactNoise.off(), seed=seed)
    found = find_symmetry(points, normals)
    assert found.kind == "revolution"
    point, direction = found.axis
    true_direction, true_point = r @ [0.0, 0.0, 1.0], t
    assert np.degrees(np.arccos(min(1.0, abs(direction @ true_direction)))) < 1.0
    offset = (point - true_point) - ((point - true_point) @ true_direction) * true_direction
    assert np.linalg.norm(offset) < 1e-3
    images, _ = found.images(points, normals)
    assert len(images) > len(points)
    assert np.max(np.abs(trimesh.proximity.signed_distance(vase, images))) < 5e-4


def test_a_box_has_its_three_mirror_planes():
    box, r, t = _posed(trimesh.creation.box(extents=(0.12, 0.08, 0.05)), 3)
    points, normals, _, _ = sample_contacts(box, 200, noise=ContactNoise.off(), seed=3)
    found = find_symmetry(points, normals)
    assert found.kind == "mirror" and len(found.planes) == 3
    for u, d in found.planes:
        assert np.degrees(np.arccos(np.max(np.abs(r.T @ u)))) < 1.0  # along one of the box's axes
        assert abs(d - u @ t) < 1e-3                                  # through its centre
    assert len(found.transforms) == 7                                 # the group of three planes
    images, _ = found.images(points, normals)
    assert np.max(np.abs(trimesh.proximity.signed_distance(box, images))) < 5e-4


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_an_irregular_body_has_none(seed):
    rng = np.random.default_rng(seed)
    body = trimesh.convex.convex_hull(rng.normal(scale=0.04, size=(14, 3)))
    for noise in (ContactNoise.off(), ContactNoise()):
        points, normals, _, _ = sample_contacts(body, 200, noise=noise, seed=seed)
        assert find_symmetry(points, normals).kind == "none"


def _cup_axis_and_radius(mug):
    """The generated mug's cup axis (x, vertical through y = 0) and outer radius, from its mesh: the
    handle lies in the y = 0 plane on +x, so the base's x extent is centred on the axis and the
    mesh's y extent is the cup's widest diameter."""
    z = mug.vertices[:, 2]
    base = mug.vertices[z < z.min() + 0.004]
    return 0.5 * (base[:, 0].min() + base[:, 0].max()), mug.bounds[1, 1]


def test_a_handle_is_a_feature_of_the_cups_revolution():
    mug = objects.load("generated:mug/0").mesh
    points, normals, _, _ = sample_contacts(mug, 300, noise=ContactNoise.off(), seed=0)
    found = find_symmetry(points, normals, GPIS(bounds=_bounds(mug)).fit(points, normals))
    assert found.kind == "revolution" and len(found.planes) == 1   # the cup's axis and the handle's plane
    x_axis, radius = _cup_axis_and_radius(mug)
    point, direction = found.axis
    assert np.degrees(np.arccos(min(1.0, abs(direction[2])))) < 2.0
    assert abs(point[0] - x_axis) < 2e-3 and abs(point[1]) < 2e-3
    on_handle = np.hypot(points[:, 0] - x_axis, points[:, 1]) > radius + 1e-3
    assert on_handle.sum() >= 10 and found.in_feature(points[on_handle]).all()
    assert found.in_feature(points).mean() <= SymmetrySettings().max_feature_share
    images, _, sources = found.images(points, normals, return_sources=True)
    turned = len(images) > 2 * len(points)                           # the body's turns copy it round
    assert turned and not on_handle[sources].all()
    off = np.abs(trimesh.proximity.signed_distance(mug, images))
    assert np.quantile(off, 0.99) < 1e-3                              # they map the mug onto itself
    # images where the cup's wall meets the handle's root lie inside the root: a few, within 5 mm
    assert off.max() < 5e-3


def test_write_mesh_counts_the_feature_contacts(tmp_path):
    from explorer.outputs import write_mesh

    mug = objects.load("generated:mug/0").mesh
    points, normals, _, _ = sample_contacts(mug, 300, noise=ContactNoise.off(), seed=0)
    gp = GPIS(bounds=_bounds(mug)).fit(points, normals)
    metrics = {}
    write_mesh(gp, 32, tmp_path, metrics, symmetry=True)  # one search: the handle test above checks what it finds
    found = metrics["reconstruction_symmetry"]
    assert found["kind"] == "revolution"
    assert 0 < found["feature_contacts"] <= SymmetrySettings().max_feature_share * len(points)
    assert found["transforms"] == 1 + (SymmetrySettings().rotations - 1)  # the handle's mirror and the body's turns


def test_without_features_the_handle_refuses_the_revolution_but_keeps_its_mirror():
    mug = objects.load("generated:mug/0").mesh
    points, normals, _, _ = sample_contacts(mug, 300, noise=ContactNoise.off(), seed=0)
    settings = SymmetrySettings(max_feature_share=None)
    found = find_symmetry(points, normals, GPIS(bounds=_bounds(mug)).fit(points, normals), settings)
    assert found.kind == "mirror" and not found.body_transforms
    images, _ = found.images(points, normals)
    assert np.max(np.abs(trimesh.proximity.signed_distance(mug, images))) < 1e-3


def test_the_bodys_turns_copy_neither_the_feature_nor_onto_it():
    # closed form: a quarter turn about z; the feature is the point at (0.05, 0, 0)
    turn = rotation(np.array([0.0, 0.0, 1.0]), np.zeros(3), np.pi / 2)
    found = Symmetry(axis=(np.zeros(3), np.array([0.0, 0.0, 1.0])), body_transforms=(turn,),
                     feature_points=np.array([[0.05, 0.0, 0.0]]), feature_radius_m=0.008)
    points = np.array([[0.05, 0.003, 0.0],    # in the feature: not turned
                       [0.0, -0.05, 0.0],     # turned onto the feature: dropped
                       [-0.05, 0.0, 0.02]])   # turned to (0, -0.05, 0.02)
    normals = points / np.linalg.norm(points, axis=1, keepdims=True)
    images, image_normals, sources = found.images(points, normals, return_sources=True)
    assert np.allclose(images, [[0.0, -0.05, 0.02]]) and sources.tolist() == [2]
    assert np.allclose(image_normals, [turn[0] @ normals[2]])
    assert found.in_feature(points).tolist() == [True, False, False]


def test_a_plane_beside_the_handle_is_refused():
    # These noisy contacts refuse the handle's own plane (94.6 % of its testable images agree);
    # a plane 10 deg off it passed the free-space test at its limit and mirrored the handle 15 mm
    # off. The planes through the cup's axis put 3.5 % of the images in free space: one that is
    # the handle's mirror must halve that.
    mug = objects.load("generated:mug/1001").mesh
    points, normals, _, _ = sample_contacts(mug, 200, seed=102)
    found = find_symmetry(points, normals, GPIS(bounds=_bounds(mug)).fit(points, normals))
    surface, _ = trimesh.sample.sample_surface(mug, 2000, seed=0)
    for m, t in found.transforms:
        off = np.abs(trimesh.proximity.signed_distance(mug, surface @ m.T + t))
        assert np.quantile(off, 0.99) < 3e-3


@pytest.mark.parametrize("seed", [0, 1])
def test_a_handle_keeps_its_mirror_in_any_pose_and_with_noise(seed):
    # Every vertical plane through the cup's axis fits the cup; only the handle's plane fits the
    # handle, and the search finds it among them (it used to stop at a plane through the cup alone).
    mug, r, t = _posed(objects.load("generated:mug/1").mesh, seed)
    points, normals, _, _ = sample_contacts(mug, 200, seed=102)
    found = find_symmetry(points, normals, GPIS(bounds=_bounds(mug)).fit(points, normals))
    assert found.kind in ("mirror", "revolution") and found.planes  # the cup's axis too, with the handle a feature
    handle_plane = r @ [0.0, 1.0, 0.0]  # the generated mug's handle lies in its y = 0 plane
    u, d = found.planes[0]
    assert np.degrees(np.arccos(min(1.0, abs(u @ handle_plane)))) < 5.0  # a plane through the cup alone: 10-90
    assert abs(abs(d) - abs(handle_plane @ t)) < 2e-3


@pytest.mark.parametrize("draw", [0, 1, 2])
def test_a_sparsely_touched_bowls_images_are_neither_outside_nor_free(draw):
    # 100 contacts on a 19 cm bowl lie about 3 cm apart: its wall bulges 5-11 mm out of their hull,
    # and the plain GPIS mean is 4-5 mm off at the rim, where it is uncertain. The true symmetry's
    # images land there; counted as outside or free (15-22 % and 3-7 % of them) they refused it.
    bowl = objects.load("generated:bowl/0").mesh  # a surface of revolution about z through 0
    points, normals, _, _ = sample_contacts(bowl, 100, seed=100 + draw)
    gpis = GPIS(bounds=_bounds(bowl)).fit(points, normals)
    settings = SymmetrySettings()
    judge = _ImageJudge(points, normals / np.linalg.norm(normals, axis=1, keepdims=True), gpis, settings)
    # Bounds with a few images' margin either way (before: outside 0.07-0.18, free 0.035-0.05 mean;
    # now at most 0.02 and 0.01), so that one image judged otherwise on another CPU changes nothing.
    shares = [judge.fractions(transform) for transform in (rotation([0.0, 0.0, 1.0], np.zeros(3), np.pi / 2),
                                                           reflection(np.array([0.0, 1.0, 0.0]), 0.0))]
    assert max(share["outside"] for share in shares) <= settings.max_outside / 2
    assert np.mean([share["free"] for share in shares]) <= settings.max_free
    assert find_symmetry(points, normals, gpis).kind != "none"


def _recorded_loop_field(name, half_extent_m):
    """The contacts (unit normals) a loop run recorded and its reconstruction field rebuilt from them
    and the field's free-space rows (``tests/data/NAME``), both faces of a thin wall tightened with
    a gain of 3 as ``LoopConfig.reconstruction_wall_gain`` does; the box is +-``half_extent_m``."""
    data = np.load(Path(__file__).parent / "data" / name)
    contacts, free = data["contacts"].astype(float), data["free"].astype(float)
    points, normals = contacts[:, :3], contacts[:, 3:] / np.linalg.norm(contacts[:, 3:], axis=1, keepdims=True)
    half = np.asarray(half_extent_m)
    gpis = GPIS(bounds=(-half, half), opposing_gradient_gain=3.0).fit(points, normals)
    gpis.add_values(free[:, :3], free[:, 3], 0.004)
    return points, normals, gpis


def test_a_field_that_misplaces_its_own_contacts_does_not_refuse_a_true_symmetry_for_it():
    # What the loop made on the tuning bowl (generated:bowl/0, variance strategy, seed 1, 100
    # touches): its 67 contacts and the 19 free-space rows of its reconstruction field, which
    # tightens both faces of a thin wall with a gain of 3 (LoopConfig.reconstruction_wall_gain).
    # That field misplaces a fifth of its own contacts, each left out, by more than the images'
    # free rule; it put 3 images of the true quarter turn in free space, and the 2 % limit refused
    # the bowl's revolution (2.86 mm with the one mirror found instead of 1.20 mm).
    points, normals, gpis = _recorded_loop_field("bowl_loop_field.npz", [0.143, 0.143, 0.076])
    settings = SymmetrySettings()
    judge = _ImageJudge(points, normals, gpis, settings)
    mean, std = gpis.leave_one_out()
    misplaced = np.mean((np.abs(mean) > settings.free_depth_m) & (np.abs(mean) > settings.free_confidence * std))
    assert judge.free_allowance == pytest.approx(misplaced) and misplaced > 4 * settings.max_free  # 0.21
    quarter_turn = rotation([0.0, 0.0, 1.0], np.zeros(3), np.pi / 2)  # the bowl's own axis
    assert settings.max_free < judge.fractions(quarter_turn)["free"] < misplaced / 2  # 0.045
    found = find_symmetry(points, normals, gpis)
    assert found.kind == "revolution"
    assert abs(found.axis[1][2]) > np.cos(np.radians(3.0))


@pytest.mark.parametrize("misplaced, contacts, raised", [(1, 46, False), (3, 100, False), (4, 67, True), (14, 67, True)])
def test_the_allowance_rises_only_when_more_contacts_are_misplaced_than_chance_gives(misplaced, contacts, raised):
    # One left-out contact of 46 deep in free space is what a 2 % rate gives by chance (binomial
    # tail 0.61); 4 of 67 is not (0.046). Only then may the images be free as often.
    class LeftOut:  # a GPIS as the judge reads it: its contacts left out, misplaced ones 6 mm deep
        use_normals = True

        def leave_one_out(self):
            mean = np.zeros(contacts)
            mean[:misplaced] = -6e-3
            return mean, np.full(contacts, 1e-3)

    points = np.random.default_rng(0).normal(scale=0.05, size=(contacts, 3))
    settings = SymmetrySettings()
    judge = _ImageJudge(points, points / np.linalg.norm(points, axis=1, keepdims=True), LeftOut(), settings)
    assert judge.free_allowance == (misplaced / contacts if raised else settings.max_free)


def test_one_image_off_a_contacts_tangent_plane_does_not_refuse_a_true_mirror():
    # What the loop made on the tuning tray (generated:tray/0, variance strategy, seed 1): 88
    # contacts and 3 free-space rows. 24 images of its true mirror x = 0 are testable and one
    # misses its neighbour's tangent plane by 2.7 mm, both contacts within 0.1 mm of the truth: the
    # neighbour's normal error over the match radius. 97 % of 24 allows none, and the tray was
    # meshed without symmetry (3.18 mm; with the mirror 2.55). Across the two normals' bisector
    # the image is within the tolerance.
    points, normals, gpis = _recorded_loop_field("tray_loop_field.npz", [0.1114, 0.1036, 0.0452])
    tangent = SymmetrySettings(across_bisector=False)
    mirror = reflection(np.array([1.0, 0.0, 0.0]), 0.0)
    judge = _ImageJudge(points, normals, gpis, tangent)
    share = judge.fractions(mirror)
    assert share["share"] < tangent.min_consistent_share and share["inconsistent_count"] == 1
    assert judge.accepts(mirror)
    assert not _ImageJudge(points, normals, gpis, replace(tangent, consistency_exceptions=0)).accepts(mirror)
    assert _ImageJudge(points, normals, gpis, SymmetrySettings()).fractions(mirror)["inconsistent_count"] == 0
    tray = objects.load("generated:tray/0").mesh
    surface, _ = trimesh.sample.sample_surface(tray, 2000, seed=0)
    found = find_symmetry(points, normals, gpis)
    assert found.kind == "mirror"
    for m, t in found.transforms:
        assert np.quantile(np.abs(trimesh.proximity.signed_distance(tray, surface @ m.T + t)), 0.99) < 3e-3


@pytest.mark.parametrize("testable, inconsistent, accepted", [(24, 1, True), (24, 2, False), (100, 3, True), (100, 4, False)])
def test_the_consistency_share_allows_one_exception_and_no_more(testable, inconsistent, accepted):
    # 97 % of the testable images must agree, or all but one: at 100 testable images 3 may fail.
    class Fractions(_ImageJudge):
        def fractions(self, transform, subset=None):
            return dict(testable=testable / 200, consistent=(testable - inconsistent) / 200,
                        share=1 - inconsistent / testable, inconsistent_count=inconsistent, outside=0.0, free=0.0)

    points = np.random.default_rng(0).normal(scale=0.05, size=(200, 3))
    judge = Fractions(points, points / np.linalg.norm(points, axis=1, keepdims=True), None, SymmetrySettings())
    assert judge.accepts(reflection(np.array([1.0, 0.0, 0.0]), 0.0)) == accepted


def test_a_field_that_misplaces_its_own_contacts_keeps_the_handles_rule():
    # What the loop made on the held-out mug (generated:mug/1000, seed 2): 77 contacts and 8
    # free-space rows, the field rebuilt as above. It misplaces a tenth of its own contacts, so
    # the images' free-space allowance rises; the planes through the cup's axis must still halve
    # their typical free share (a handle refused the axis), or a plane through the cup alone
    # mirrors the handle 19 mm off the truth.
    points, normals, gpis = _recorded_loop_field("mug_loop_field.npz", [0.0793, 0.0665, 0.0823])
    settings = SymmetrySettings()
    judge = _ImageJudge(points, normals, gpis, settings)
    assert judge.free_allowance > 2 * settings.max_free  # 0.10
    mug = objects.load("generated:mug/1000").mesh
    surface, _ = trimesh.sample.sample_surface(mug, 2000, seed=0)
    for m, t in find_symmetry(points, normals, gpis).transforms:
        off = np.abs(trimesh.proximity.signed_distance(mug, surface @ m.T + t))
        assert np.quantile(off, 0.99) < 3e-3


def test_too_few_contacts_say_nothing():
    vase = _vase()
    points, normals, _, _ = sample_contacts(vase, 10, noise=ContactNoise.off(), seed=0)
    assert find_symmetry(points, normals) == Symmetry()


def _bounds(mesh):
    lo, hi = mesh.bounds
    pad = 0.2 * float(np.max(hi - lo))
    return lo - pad, hi + pad


def test_the_mesh_with_symmetry_fills_gaps_and_leaves_the_gpis_alone():
    vase, _, _ = _posed(_vase(), 5)
    points, normals, _, _ = sample_contacts(vase, 80, seed=5)
    gp = GPIS(bounds=_bounds(vase)).fit(points, normals)
    probe = vase.vertices[:50]
    before = gp.mean(probe).copy()
    plain = surface_error(gp.mesh(resolution=48), vase).position_rmse_mm
    symmetric = surface_error(gp.mesh(resolution=48, symmetry=True), vase).position_rmse_mm
    assert np.array_equal(gp.mean(probe), before) and gp.n_contacts == 80
    assert symmetric < 0.8 * plain


def _sphere_with_a_stem():
    """A 40 mm sphere about the origin with a stem (4 mm radius) up to z = 65 mm: the mirror z = 0
    maps all of it onto itself but the stem, a fruit's near symmetry."""
    stem = trimesh.creation.cylinder(radius=0.004, height=0.03)
    stem.apply_translation([0.0, 0.0, 0.05])
    return trimesh.boolean.union([trimesh.creation.icosphere(subdivisions=4, radius=0.04), stem])


_TOP_BOTTOM = Symmetry((reflection(np.array([0.0, 0.0, 1.0]), 0.0),), ((np.array([0.0, 0.0, 1.0]), 0.0),), None)


def test_images_are_contradicted_only_outside_the_hull_and_deep_in_free_space():
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=0.04)
    points, normals, _, _ = sample_contacts(sphere, 200, noise=ContactNoise.off(), seed=1)
    gp = GPIS(bounds=_bounds(sphere)).fit(points, normals)
    d = np.random.default_rng(0).normal(size=(100, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    assert not contradicted_images(gp, 0.04 * d).any()          # on the surface
    assert contradicted_images(gp, 0.065 * d).all()             # 25 mm out: beyond the hull, free
    assert not contradicted_images(gp, 0.02 * d).any()          # deep in solid, but inside the hull
    assert not contradicted_images(gp, np.zeros((0, 3))).any()


def test_images_of_the_hemisphere_left_untouched_are_not_contradicted():
    # outside the hull alone is no contradiction: the mean does not put them deep in free space
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=0.04)
    points, normals, _, _ = sample_contacts(sphere, 300, noise=ContactNoise.off(), seed=2)
    upper = points[:, 2] > 0.01
    gp = GPIS(bounds=_bounds(sphere)).fit(points[upper], normals[upper])
    images, _ = _TOP_BOTTOM.images(gp.contact_points, gp.contact_normals)
    judge = _ImageJudge(gp.contact_points, gp.contact_normals, None, SymmetrySettings())
    outside = judge.fractions(reflection(np.array([0.0, 0.0, 1.0]), 0.0))["outside"]
    assert outside > 0.5                                         # most images lie beyond the hull
    assert contradicted_images(gp, images).mean() < 0.05


def test_a_feature_the_symmetry_does_not_hold_for_is_not_copied():
    body = _sphere_with_a_stem()
    points, normals, _, _ = sample_contacts(body, 200, noise=ContactNoise.off(), seed=1)
    gp = GPIS(bounds=_bounds(body)).fit(points, normals)
    images, image_normals = _TOP_BOTTOM.images(gp.contact_points, gp.contact_normals)
    stem_images = images[:, 2] < -0.042
    contradicted = contradicted_images(gp, images)
    assert stem_images.any() and contradicted[stem_images].all() and not contradicted[~stem_images].any()
    assert gp.mesh(resolution=48, symmetry=_TOP_BOTTOM).vertices[:, 2].min() > -0.045
    lo, hi = gp.region                                            # every image in the region, as before
    inside = np.all((images > lo) & (images < hi), axis=1)
    every = copy.deepcopy(gp)
    every.add(images[inside], image_normals[inside])
    assert every.mesh(resolution=48).vertices[:, 2].min() < -0.05  # a stem grown below


def test_a_copy_of_the_gpis_meshes_the_same():
    box = trimesh.creation.box(extents=(0.1, 0.07, 0.04))
    points, normals, _, _ = sample_contacts(box, 80, noise=ContactNoise.off(), seed=2)
    gp = GPIS(bounds=_bounds(box)).fit(points, normals)
    a = gp.mesh(resolution=32, symmetry=True)
    b = copy.deepcopy(gp).mesh(resolution=32, symmetry=True)
    assert np.allclose(a.vertices, b.vertices)


def test_write_mesh_says_what_symmetry_it_used(tmp_path):
    from explorer.outputs import write_mesh

    box = trimesh.creation.box(extents=(0.1, 0.07, 0.04))
    points, normals, _, _ = sample_contacts(box, 120, noise=ContactNoise.off(), seed=4)
    gp = GPIS(bounds=_bounds(box)).fit(points, normals)
    metrics = {}
    write_mesh(gp, 32, tmp_path, metrics, symmetry=True)
    assert metrics["reconstruction_symmetry"] == dict(kind="mirror", transforms=7, feature_contacts=0, disputed_contacts=0)
    plain = {}
    write_mesh(gp, 32, tmp_path, plain)
    assert "reconstruction_symmetry" not in plain
    points[7] += 5e-3 * normals[7]  # a contact standing off a face: its images are left out
    moved = {}
    mesh = write_mesh(GPIS(bounds=_bounds(box)).fit(points, normals), 32, tmp_path, moved, symmetry=True)
    assert moved["reconstruction_symmetry"] == dict(kind="mirror", transforms=7, feature_contacts=0, disputed_contacts=1)
    assert mesh.metadata["symmetry_disputed_contacts"].tolist() == [7]


def test_sessions_recorded_before_the_setting_replay_without_it(recorded_sphere_run, tmp_path):
    from explorer.replay import SessionReplay
    from fakes import session_recorded_without

    session = recorded_sphere_run.out_dir / "session"
    assert SessionReplay(session).loop_config.reconstruction_symmetry
    old = session_recorded_without(session, tmp_path / "old-session", "reconstruction_symmetry")
    assert not SessionReplay(old).loop_config.reconstruction_symmetry


def test_replay_meshes_with_or_without_the_images_as_asked(recorded_sphere_run, tmp_path):
    from explorer.replay import ReplaySettings, replay

    session = recorded_sphere_run.out_dir / "session"
    on = replay(session, ReplaySettings(figures=False), tmp_path / "on")
    off = replay(session, ReplaySettings(figures=False, reconstruction_symmetry=False), tmp_path / "off")
    assert on.metrics["reconstruction_symmetry"]["kind"] in ("none", "mirror", "revolution")
    assert "reconstruction_symmetry" not in off.metrics


def test_explore_without_symmetry_turns_the_loop_setting_off():
    from explorer.run import RunSettings
    from scripts.explore import _without_symmetry

    settings = _without_symmetry(RunSettings(object="sphere"))
    assert settings.loop.reconstruction_symmetry is False and RunSettings().loop.reconstruction_symmetry


def test_write_mesh_meshes_a_partitioned_gpis_without_images(tmp_path):
    from explorer.outputs import write_mesh
    from reconstruction.partitioned_gpis import PartitionedGPIS

    box = trimesh.creation.box(extents=(0.1, 0.07, 0.04))
    points, normals, _, _ = sample_contacts(box, 60, noise=ContactNoise.off(), seed=6)
    metrics = {}
    assert write_mesh(PartitionedGPIS(_bounds(box)).fit(points, normals), 24, tmp_path, metrics, symmetry=True) is not None
    assert "reconstruction_symmetry" not in metrics


def _wedge(length=0.14, height=0.05, width=0.07):
    """A door-stop wedge: tip edge along y through the origin, bottom z = 0, end face x = length;
    and the unit normal of the plane through the tip halving the top and the bottom."""
    corners = [(x, y, z) for x, z in ((0.0, 0.0), (length, 0.0), (length, height)) for y in (-width / 2, width / 2)]
    wedge = trimesh.convex.convex_hull(np.array(corners))
    slope = np.arctan2(height, length)
    top, bottom = np.array([-np.sin(slope), 0.0, np.cos(slope)]), np.array([0.0, 0.0, -1.0])
    return wedge, (top - bottom) / np.linalg.norm(top - bottom)


def test_a_wedges_plane_between_top_and_bottom_turns_its_end_face_and_is_refused():
    wedge, between = _wedge()
    points, normals, _, _ = sample_contacts(wedge, 200, seed=0)  # the default sensor noise
    judge = _ImageJudge(points, normals / np.linalg.norm(normals, axis=1, keepdims=True), None, SymmetrySettings())
    false = reflection(between, 0.0)
    # the plane maps top onto bottom exactly; only the end face's faces are turned (by the slope, 20 deg)
    conflicts = judge.face_conflicts(false)
    assert conflicts.any()
    assert np.all(judge.faces.normals[conflicts] @ [1.0, 0.0, 0.0] > 0.95)
    assert not judge.accepts(false)
    assert not judge.face_conflicts(reflection(np.array([0.0, 1.0, 0.0]), 0.0)).any()


def test_a_generated_wedge_keeps_its_true_plane_and_not_the_one_between_top_and_bottom():
    # tuning wedge/1 with 200 contacts as the faithfulness benchmark drew them (independent
    # draws): without the face test the plane halving its top and bottom was accepted beside
    # y = 0 (1.06 mm against 0.55)
    wedge = objects.load("generated:wedge/1").mesh
    points, normals, _, _ = sample_contacts(wedge, 200, seed=100)
    found = GPIS(bounds=_bounds(wedge)).fit(points, normals).symmetry()
    assert all(abs(u[1]) > 0.99 for u, _ in found.planes)  # y = 0 or none, never the plane between


@pytest.mark.parametrize("degrees, conflict", [(4.0, False), (30.0, True)])
def test_a_face_turned_onto_itself_conflicts_only_beyond_its_allowance(degrees, conflict):
    # a turn about a line in the end face through its centre keeps the face's centre and turns its
    # normal: within the faces' tilts and face_conflict_rad no conflict, beyond them one
    wedge, _ = _wedge()
    points, normals, _, _ = sample_contacts(wedge, 200, noise=ContactNoise.off(), seed=1)
    judge = _ImageJudge(points, normals, None, SymmetrySettings())
    end = judge.faces.fitted & (judge.faces.normals @ [1.0, 0.0, 0.0] > 0.99)
    assert end.sum() >= 5
    centre = judge.faces.centres[end].mean(axis=0)
    turn = rotation(np.array([0.0, 1.0, 0.0]), centre, np.radians(degrees))
    assert judge.face_conflicts(turn)[end].any() == conflict


def test_an_image_on_a_sphere_is_off_its_neighbours_tangent_plane_but_not_off_the_bisectors_plane():
    # closed form: two points of a sphere of radius R whose normals are theta apart lie
    # R (1 - cos theta) apart along either normal, and on one plane across their normals' bisector
    radius = 0.01
    directions = np.random.default_rng(3).normal(size=(300, 3))
    normals = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    points = radius * normals
    judge = _ImageJudge(points, normals, None, SymmetrySettings())
    turn = rotation(np.array([0.3, -0.2, 1.0]) / np.linalg.norm([0.3, -0.2, 1.0]), np.zeros(3), np.radians(37.0))
    images, tangent, _, _ = judge._residuals(turn, neighbours=len(points))
    _, bisector, _, _ = judge._residuals(turn, neighbours=len(points), across_bisector=True)
    tested = np.isfinite(tangent)
    assert tested.sum() > 100
    cos_theta = images[tested] @ points.T / radius ** 2  # (tested, contacts)
    near = np.linalg.norm(images[tested][:, None, :] - points[None], axis=2) < judge.s.match_radius_m
    agreeing = near & (cos_theta > np.cos(judge.s.normal_cone_rad))
    expected = np.min(np.where(agreeing, radius * (1.0 - cos_theta), np.inf), axis=1)
    np.testing.assert_allclose(tangent[tested], expected, atol=1e-12)
    assert np.isfinite(bisector[tested]).all() and np.abs(bisector[tested]).max() < 1e-12


def test_a_generated_plates_axis_is_accepted_at_200_contacts():
    # tuning plate/1, draw 0 of the faithfulness benchmark (independent draws): against the
    # contacts' tangent planes 5 of 96 images of a 37 deg turn about the found axis missed by the
    # rim's curvature, and the revolution found at 100 contacts was refused at 200 (0.59 -> 0.94
    # mm). Now 1 of 96 misses (2 may); at 100 contacts the axis rests on 2 of 28 images and is not
    # asserted here.
    plate = objects.load("generated:plate/1").mesh
    points, normals, _, _ = sample_contacts(plate, 200, seed=100)
    found = GPIS(bounds=_bounds(plate)).fit(points, normals).symmetry()
    assert found.kind == "revolution"
    assert abs(found.axis[1][2]) > 0.999


@pytest.mark.parametrize("offset_mm, worse", [(0.0, False), (1.0, True)])
def test_a_spheres_mirror_off_its_centre_has_images_the_gpis_predicts_worse_than_its_contacts(offset_mm, worse):
    # closed form: a mirror plane d from a sphere's centre maps the sphere onto one 2 d away, so
    # the images lie up to 2 d off the surface that 200 contacts pin to a fraction of a millimetre;
    # through the centre they are surface points the GPIS has not seen, like a contact left out
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=0.04)
    points, normals, _, _ = sample_contacts(sphere, 200, seed=0)
    gpis = GPIS(bounds=_bounds(sphere)).fit(points, normals)
    judge = _ImageJudge(points, normals / np.linalg.norm(normals, axis=1, keepdims=True), gpis, SymmetrySettings())
    m, t = reflection(np.array([0.0, 0.0, 1.0]), 1e-3 * offset_mm)
    assert judge._images_worse_predicted(points @ m.T + t) == worse


def test_a_blobs_near_axis_is_refused_for_images_the_gpis_predicts_worse_than_its_contacts():
    # tuning blob/1 (a sphere displaced by an ellipsoid and bumps: no symmetry), draw 1 of the
    # faithfulness benchmark (independent draws) at 200 contacts: the other tests accept an axis
    # of revolution the blob nearly has (its truth turned lies within 1.1 mm of itself at the 90th
    # percentile), and the mesh with its images was 0.46 mm from the truth; now a mirror the blob
    # has more nearly is kept (0.20 mm)
    blob = objects.load("generated:blob/1").mesh
    points, normals, _, _ = sample_contacts(blob, 200, seed=101)
    gpis = GPIS(bounds=_bounds(blob)).fit(points, normals)
    without = find_symmetry(points, normals, gpis, replace(SymmetrySettings(), prediction_significance=None))
    assert without.kind == "revolution"
    judge = _ImageJudge(points, normals / np.linalg.norm(normals, axis=1, keepdims=True), gpis, SymmetrySettings())
    assert all(judge._images_worse_predicted(points @ m.T + t) for m, t in without.transforms)
    found = find_symmetry(points, normals, gpis)
    assert found.kind != "revolution"
    # independent of the GPIS: how far each transform moves the true surface off itself
    truth = MeshProximity(blob)
    surface = sample_surface(blob, 4000, np.random.default_rng(0))[0]
    off_truth = lambda m, t: np.percentile(truth.query(surface @ m.T + t)[1], 90)  # noqa: E731
    assert all(off_truth(*kept) < min(off_truth(*refused) for refused in without.transforms)
               for kept in found.transforms)


def _vase_turns(turns=16):
    """The vase's revolution about z as ``turns - 1`` rotations."""
    transforms = tuple(rotation(np.array([0.0, 0.0, 1.0]), np.zeros(3), 2 * np.pi * k / turns)
                       for k in range(1, turns))
    return Symmetry(transforms, (), (np.zeros(3), np.array([0.0, 0.0, 1.0])))


def test_images_name_the_contact_they_copy():
    vase = _vase()
    points, normals, _, _ = sample_contacts(vase, 40, noise=ContactNoise.off(), seed=0)
    found = replace(_vase_turns(), merge_images=False)  # each image one copy, not a mean
    images, image_normals, sources = found.images(points, normals, return_sources=True)
    np.testing.assert_array_equal(np.column_stack(found.images(points, normals)), np.column_stack([images, image_normals]))
    copies = np.stack([points[sources] @ m.T + t for m, t in found.transforms])   # (transforms, k, 3)
    assert np.all(np.min(np.linalg.norm(copies - images, axis=2), axis=0) < 1e-12)
    assert len(np.unique(sources)) > 0.9 * len(points)


def test_competing_images_keep_the_copy_of_the_contact_ranked_first():
    # Two contacts 2 mm apart: their mirror images are 2 mm apart too, nearer than the 3 mm gap, so
    # only one is kept; the lower priority wins, without priorities the first transform's.
    points = np.array([[0.02, 0.0, 0.0], [0.02, 0.002, 0.0]])
    normals = np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    mirror = Symmetry((reflection(np.array([1.0, 0.0, 0.0]), 0.0),), ((np.array([1.0, 0.0, 0.0]), 0.0),),
                      merge_images=False)
    for priority, kept in ((None, 0), ([1.0, 0.0], 1), ([0.0, 1.0], 0)):
        images, image_normals, sources = mirror.images(points, normals, return_sources=True, priority=priority)
        assert sources.tolist() == [kept]
        np.testing.assert_allclose(images[0], points[kept] * [-1.0, 1.0, 1.0])
        np.testing.assert_allclose(image_normals[0], [-1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="one value per contact"):
        mirror.images(points, normals, priority=[0.0, 1.0, 2.0])


@pytest.mark.parametrize("rank", [True, False])
def test_ranked_images_do_not_depend_on_the_order_of_the_turns(rank):
    # Which of two competing images is kept came from the order of the turns, and decided a fruit's
    # stem (BENCHMARKS.md, "Competing images ranked by their contacts"); ranked (an option) by how well the
    # other observations predict each image's contact, the same contacts give the same images
    # however the turns are listed. Unranked, the reversed list keeps others: the test can fail.
    vase = _vase()
    points, normals, _, _ = sample_contacts(vase, 80, seed=3)
    gpis = GPIS(bounds=_bounds(vase)).fit(points, normals)
    found = replace(_vase_turns(8), rank_images=rank, merge_images=False)
    reversed_turns = replace(found, transforms=found.transforms[::-1])
    observed = [np.array(sorted(map(tuple, np.round(gpis._with_symmetric_images(s)[0].contact_points, 12))))
                for s in (found, reversed_turns)]
    same = observed[0].shape == observed[1].shape and np.array_equal(observed[0], observed[1])
    assert same == rank
    assert len(observed[0]) > 80 + 3 * 80  # images were kept, not all refused


def test_merged_images_are_the_mean_of_the_copies_that_compete():
    # Two contacts 2 mm apart mirror into copies 2 mm apart, nearer than the 3 mm gap: merged, they
    # are one image at the copies' mean with their mean normal. A third contact's copy within the
    # gap but facing the other way (a thin wall's other side) does not compete; a fourth contact on
    # the mirror plane has its copy on itself, near a contact: left out.
    tilt = np.array([1.0, 0.1, 0.0]) / np.linalg.norm([1.0, 0.1, 0.0])
    points = np.array([[0.02, 0.0, 0.0], [0.02, 0.002, 0.0], [0.021, 0.001, 0.0], [0.0, 0.05, 0.0]])
    normals = np.array([[1.0, 0.0, 0.0], tilt, [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    mirror = Symmetry((reflection(np.array([1.0, 0.0, 0.0]), 0.0),), ((np.array([1.0, 0.0, 0.0]), 0.0),))
    assert mirror.merge_images  # the default
    images, image_normals, sources = mirror.images(points, normals, return_sources=True)
    flip = np.array([-1.0, 1.0, 1.0])
    assert len(images) == 2
    np.testing.assert_allclose(images[0], (points[0] + points[1]) / 2 * flip)
    expected = (normals[0] + normals[1]) * flip
    np.testing.assert_allclose(image_normals[0], expected / np.linalg.norm(expected))
    np.testing.assert_allclose(images[1], points[2] * flip)
    np.testing.assert_allclose(image_normals[1], [1.0, 0.0, 0.0])
    assert sources.tolist() == [0, 2]
    kept_first = replace(mirror, merge_images=False).images(points, normals, return_sources=True)[2]
    assert kept_first.tolist() == [0]  # the first rule: one copy decides, the facing one is crowded out


@pytest.mark.parametrize("seed", [0, 3])
def test_merged_images_move_less_with_the_order_of_the_turns_and_lie_nearer_the_surface(seed):
    # Which of several competing copies is kept came from the order of the turns (BENCHMARKS.md,
    # "Competing images ranked by their contacts"). Merged, a turn listed elsewhere changes only which
    # copy leads a group, not that all of them are averaged: the images move by a small part of what
    # the first-kept images move, and the averaged noise puts them nearer the true vase.
    vase = _vase()
    points, normals, _, _ = sample_contacts(vase, 80, seed=seed)
    moved, off_surface = {}, {}
    for merge in (False, True):
        found = replace(_vase_turns(8), merge_images=merge)
        a, _ = found.images(points, normals)
        b, _ = replace(found, transforms=found.transforms[::-1]).images(points, normals)
        moved[merge] = np.mean(np.concatenate([cKDTree(b).query(a)[0], cKDTree(a).query(b)[0]]))
        off_surface[merge] = np.sqrt(np.mean(MeshProximity(vase).query(a)[1] ** 2))
        assert len(a) > 3 * 80
    assert moved[True] < 0.3 * moved[False]
    assert off_surface[True] < off_surface[False]


@pytest.mark.parametrize("moved_mm, disputed", [(5.0, True), (-5.0, False), (0.0, False)])
def test_a_contact_off_the_surface_loses_its_images(moved_mm, disputed):
    # One contact moved along its normal: out into free space (a pad's rim standing off an edge)
    # its 15 images would put surface where the other contacts' images say there is none; left out
    # of the field with the images, it is predicted that deep in free space, so its images are not
    # observed. Moved into the solid, where a pad cannot sink, it keeps them: it is the others
    # that are wrong there.
    vase = _vase()
    points, normals, _, _ = sample_contacts(vase, 80, noise=ContactNoise.off(), seed=4)
    points[0] += 1e-3 * moved_mm * normals[0]
    found = _vase_turns()
    gpis = GPIS(bounds=_bounds(vase)).fit(points, normals)
    images, image_normals, sources = found.images(points, normals, return_sources=True)
    model = copy.deepcopy(gpis).add(images, image_normals)
    flagged = disputed_contacts(model, 80)
    assert flagged.shape == (80,)
    assert np.flatnonzero(flagged).tolist() == ([0] if disputed else [])
    meshed, left_out = gpis._with_symmetric_images(found)
    np.testing.assert_array_equal(left_out, flagged)
    turned = np.array([m @ points[0] + t for m, t in found.transforms])
    nearest = cKDTree(meshed.contact_points).query(turned)[0]
    assert (np.max(nearest) > 2e-3) == disputed          # the moved contact's images are gone
    assert meshed.n_contacts > 0.8 * (80 + len(images))  # the others' are kept
    assert np.max(np.abs(trimesh.proximity.signed_distance(vase, meshed.contact_points[80:]))) < (
        5e-4 if disputed or moved_mm == 0 else 6e-3)


def test_no_dispute_when_switched_off():
    vase = _vase()
    points, normals, _, _ = sample_contacts(vase, 40, noise=ContactNoise.off(), seed=4)
    points[0] += 5e-3 * normals[0]
    found = _vase_turns()
    images, image_normals = found.images(points, normals)
    model = GPIS(bounds=_bounds(vase)).fit(np.vstack([points, images]), np.vstack([normals, image_normals]))
    assert disputed_contacts(model, 40).any()
    assert not disputed_contacts(model, 40, replace(SymmetrySettings(), dispute_depth_m=None)).any()


def _tilted(direction, degrees, towards):
    """``direction`` turned by ``degrees`` towards the unit vector ``towards`` (perpendicular to it)."""
    a = np.radians(degrees)
    return np.cos(a) * np.asarray(direction, float) + np.sin(a) * np.asarray(towards, float)


def test_a_cones_profile_misfit_is_zero_about_its_axis_wherever_the_point_lies_on_it():
    # Exact points of a cone's side about z: in (height, radius) they lie on one straight line, so
    # every contact's distance from the line through its profile neighbours is zero (closed form);
    # off the axis the radius varies with the azimuth and the profile thickens.
    rng = np.random.default_rng(0)
    height, azimuth = rng.uniform(-0.05, 0.05, 300), rng.uniform(0.0, 2 * np.pi, 300)
    radius = 0.04 + 0.2 * height
    points = np.column_stack([radius * np.cos(azimuth), radius * np.sin(azimuth), height])
    normals = np.column_stack([np.cos(azimuth), np.sin(azimuth), -0.2 * np.ones(300)])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    z = np.array([0.0, 0.0, 1.0])
    for along in (0.0, 0.03):
        assert profile_misfit(points, normals, z, along * z, 5e-4) < 1e-12
    assert profile_misfit(points, normals, _tilted(z, 2.0, [1.0, 0.0, 0.0]), np.zeros(3), 5e-4) > 0.05
    assert profile_misfit(points, normals, z, np.array([0.002, 0.0, 0.0]), 5e-4) > 0.05


def test_a_bowls_axis_is_polished_from_a_start_degrees_off():
    # 150 noisy contacts on the tuning bowl (its axis z through the origin), four draws; the polish
    # starts 2 deg and 2 mm off, where the images' soft score is flat (BENCHMARKS.md, "An axis
    # polished by its profile"). It never thickens the profile, and typically lands within a few
    # tenths of a degree (a local search may stop short on one draw of several).
    bowl = objects.load("generated:bowl/0").mesh
    z, start_point, settings = np.array([0.0, 0.0, 1.0]), np.array([0.002, -0.001, 0.0]), SymmetrySettings()
    tilts, offsets = [], []
    for seed in range(4):
        points, normals, _, _ = sample_contacts(bowl, 150, seed=seed)
        normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
        start = _tilted(z, 2.0, [np.cos(seed), np.sin(seed), 0.0])
        direction, point = _polish_axis(points, normals, start, start_point, settings)
        fine = settings.profile_scales_m[-1]
        assert profile_misfit(points, normals, direction, point, fine) <= profile_misfit(points, normals, start, start_point, fine)
        tilts.append(np.degrees(np.arccos(min(1.0, abs(direction @ z)))))
        offsets.append(np.linalg.norm(point - (point @ direction) * direction))
    assert np.median(tilts) < 0.5 and np.median(offsets) < 1e-3
    assert _polish_axis(points, normals, start, start_point, SymmetrySettings(profile_scales_m=())) is None


def test_an_accepted_axis_is_the_polished_one():
    # tuning bowl/0, draw 1 of the faithfulness benchmark at 100 contacts: the images' refinement
    # accepted an axis 1.9 deg off (0.97 mm); the polished axis is accepted instead.
    bowl = objects.load("generated:bowl/0").mesh
    points, normals, _, _ = sample_contacts(bowl, 100, seed=101, pool=4000)
    gpis = GPIS(bounds=_bounds(bowl)).fit(points, normals)
    tilt = {}
    for name, settings in (("polished", SymmetrySettings()), ("refined", SymmetrySettings(profile_scales_m=()))):
        found = find_symmetry(gpis.contact_points, gpis.contact_normals, gpis, settings)
        assert found.kind == "revolution"
        tilt[name] = np.degrees(np.arccos(min(1.0, abs(found.axis[1][2]))))
    assert tilt["polished"] < min(0.5, tilt["refined"] / 2)


def _judge_of_sampled(name, n_contacts, seed, settings):
    """The image judge of ``n_contacts`` contacts sampled on a generated object as the faithfulness
    benchmark draws them (nested pool), with their default GPIS."""
    mesh = objects.load(name).mesh
    points, normals, _, _ = sample_contacts(mesh, n_contacts, seed=seed, pool=4000)
    gpis = GPIS(bounds=_bounds(mesh)).fit(points, normals)
    return _ImageJudge(gpis.contact_points, gpis.contact_normals, gpis, settings)


def test_symmetry_settings_name_a_bad_planes_axis_option():
    with pytest.raises(ValueError, match="polish_planes_axis"):
        SymmetrySettings(polish_planes_axis="revolutoin")


def test_mirror_planes_move_with_their_axis_onto_the_polished_one():
    # Closed form: a plane through the old axis z comes to contain the new, tilted axis; a plane
    # across z (z = 0.01) comes to be perpendicular to the new axis through the old axis's point
    # on it; a plane oblique to the axis stays.
    z, x = np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0])
    new_v = _tilted(z, 2.0, [0.6, 0.8, 0.0])
    new_point = np.array([0.001, -0.002, 0.0])
    w, d = _replaced(x, 0.0, z, np.zeros(3), new_v, new_point)
    assert abs(w @ new_v) < 1e-12 and abs(w @ new_point - d) < 1e-12 and w @ x > 0.999
    w, d = _replaced(z, 0.01, z, np.zeros(3), new_v, new_point)
    assert np.allclose(w, new_v) and np.isclose(d, new_v @ [0.0, 0.0, 0.01])
    oblique = np.array([0.0, 0.6, 0.8])
    w, d = _replaced(oblique, 0.02, z, np.zeros(3), new_v, new_point)
    assert np.array_equal(w, oblique) and d == 0.02


def test_a_mirror_planes_crossing_axis_is_polished_by_its_profile():
    # The tuning bowl (axis z through the origin), 200 contacts: where the normal lines fit no axis
    # the one two mirror planes cross in can be 1.4 deg and 1.2 mm off (BENCHMARKS.md, "The mirror
    # planes' axis polished by its profile"); from such a start the polish lands within half a
    # degree and a millimetre, on a thinner profile, and the turns about it pass.
    settings = SymmetrySettings()
    judge = _judge_of_sampled("generated:bowl/0", 200, 100, settings)
    z = np.array([0.0, 0.0, 1.0])
    start, start_point = _tilted(z, 1.4, [0.8, -0.6, 0.0]), np.array([0.0012, 0.0, 0.0])
    direction, point = _polish_planes_axis(judge, start, start_point, settings)
    assert _turns_accepted(judge, direction, point)
    assert np.degrees(np.arccos(min(1.0, abs(direction @ z)))) < 0.5
    assert np.linalg.norm(point - (point @ direction) * direction) < 1e-3
    fine = settings.profile_scales_m[-1]
    assert (profile_misfit(judge.points, judge.normals, direction, point, fine)
            < profile_misfit(judge.points, judge.normals, start, start_point, fine))
    assert _polish_planes_axis(judge, start, start_point, replace(settings, polish_planes_axis=None)) is None


def test_a_plates_refused_axis_is_rescued_by_its_profile():
    # The tuning plate (axis z through the origin), 100 contacts: an axis 4 deg off is refused by
    # its turns' images (the rim moves by several millimetres); polished from it and from starts
    # tilted about it, the profile finds an axis the turns accept, within half a degree of z.
    settings = SymmetrySettings()
    judge = _judge_of_sampled("generated:plate/0", 100, 102, settings)
    z = np.array([0.0, 0.0, 1.0])
    start, start_point = _tilted(z, 4.0, [0.6, 0.8, 0.0]), np.array([0.001, 0.002, 0.0])
    assert not _turns_accepted(judge, start, start_point)
    direction, point = _rescue_axis(judge, start, start_point, settings)
    assert _turns_accepted(judge, direction, point)
    assert np.degrees(np.arccos(min(1.0, abs(direction @ z)))) < 0.5
    assert np.linalg.norm(point - (point @ direction) * direction) < 1e-3
    assert _rescue_axis(judge, start, start_point, replace(settings, rescue_starts=None)) is None


def test_no_axis_is_rescued_on_a_body_without_one():
    # A chamfered box and an L-shaped tool have no axis of revolution: whatever axis their normals
    # fit best, no polish of it makes the turns' images pass.
    for name in ("generated:chamfered_box/0", "generated:l_tool/0"):
        mesh = objects.load(name).mesh
        points, normals, _, _ = sample_contacts(mesh, 150, seed=100, pool=4000)
        gpis = GPIS(bounds=_bounds(mesh)).fit(points, normals)
        judge = _ImageJudge(gpis.contact_points, gpis.contact_normals, gpis, SymmetrySettings())
        direction, point = _fit_axis(judge.points, judge.normals)
        assert _rescue_axis(judge, direction, point, SymmetrySettings()) is None, name


def test_the_mirror_across_an_axis_is_placed_where_the_profile_maps_onto_itself():
    # A spheroid along z (semi-axes 30 and 45 mm), its middle at z = 12 mm: exact contacts (no
    # noise) map onto its profile across z = 12 mm (residuals of micrometres, the facets'), not
    # across 1.5 mm above it, and a start there is moved to within a tenth of a millimetre.
    spheroid = trimesh.creation.icosphere(subdivisions=5, radius=0.03)
    spheroid.apply_scale([1.0, 1.0, 1.5])
    spheroid.apply_translation([0.0, 0.0, 0.012])
    noiseless = ContactNoise(normal_std_m=0.0, tangent_std_m=0.0, normal_error_mean_deg=0.0)
    points, normals, _, _ = sample_contacts(spheroid, 200, noise=noiseless, seed=4)
    z, origin = np.array([0.0, 0.0, 1.0]), np.zeros(3)
    assert np.nanmedian(_mirrored_profile_residuals(points, normals, z, origin, 0.012)) < 1e-4
    assert np.nanmedian(_mirrored_profile_residuals(points, normals, z, origin, 0.0135)) > 1e-3
    assert abs(_mirror_offset(points, normals, z, origin, 0.0135, 5e-4) - 0.012) < 1e-4


def _stemmed_sphere():
    """A sphere of 30 mm radius about the origin with a stem 3 mm thick standing 20 mm out of its top."""
    sphere = trimesh.creation.icosphere(subdivisions=5, radius=0.03)
    stem = trimesh.creation.cylinder(radius=0.003, height=0.03, sections=48)
    stem.apply_translation([0.0, 0.0, 0.035])
    return trimesh.boolean.union([sphere, stem], engine="manifold")


def test_the_mirror_across_an_axis_leaves_a_stem_out():
    # Mirror-symmetric across its equator z = 0 but for the stem: the stem's contacts mirrored
    # land in the free space under the sphere. They are left out of the mirror, and no contact of
    # the lower half is; the plain sphere leaves nothing out.
    settings = SymmetrySettings()
    z, origin = np.array([0.0, 0.0, 1.0]), np.zeros(3)
    for body, stemmed in ((_stemmed_sphere(), True), (trimesh.creation.icosphere(subdivisions=5, radius=0.03), False)):
        points, normals, _, _ = sample_contacts(body, 300, seed=3)
        gpis = GPIS(bounds=_bounds(body)).fit(points, normals)
        judge = _ImageJudge(gpis.contact_points, normals / np.linalg.norm(normals, axis=1, keepdims=True), gpis, settings)
        feature = _feature_of_mirror(judge, z, origin, 0.0, settings)
        if not stemmed:
            assert feature is None
            continue
        on_stem = judge.points[:, 2] > 0.031
        assert on_stem.sum() >= 3 and feature[on_stem].all()
        assert not feature[judge.points[:, 2] < 0.0].any()
        assert _feature_of_mirror(judge, z, origin, 0.0, replace(settings, mirror_by_profile=False)) is None
