"""The normal error against a mesh's normal cone (objects.proximity), checked against closed forms
on a box and against a brute-force search of the cone."""
import numpy as np
import pytest
import trimesh

from explorer.evaluation import reconstruction_errors
from objects import proximity
from objects.proximity import MeshProximity, angle_to_cone


def unit(v) -> np.ndarray:
    v = np.asarray(v, float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


@pytest.fixture(scope="module")
def cube():
    """The cube [-1, 1]^3 (12 triangles: each face split along a diagonal)."""
    return trimesh.creation.box((2.0, 2.0, 2.0))


@pytest.mark.parametrize("normal, expected_deg", [
    ([1, 0, 1], 0.0),                                   # the bisector: inside the cone
    ([1, 0, 0], 0.0), ([0, 0, 1], 0.0),                 # either face's own normal
    ([1, 0, 0.3], 0.0),                                 # anywhere between them
    ([1, 0, -0.2], np.degrees(np.arctan(0.2))),         # past the +x face: the angle to it
    ([1, 0.3, 1], np.degrees(np.arcsin(0.3 / np.sqrt(2.09)))),  # out of the arc's plane
])
def test_on_an_edge_the_error_is_the_angle_to_the_arc_between_the_two_faces(cube, normal, expected_deg):
    point = np.array([[1.5, 0.2, 1.5]])  # closest point (1, 0.2, 1): on the edge of the +x and +z faces
    error = MeshProximity(cube).normal_cone_error(point, unit(normal)[None])
    assert np.degrees(error[0]) == pytest.approx(expected_deg, abs=1e-9)


@pytest.mark.parametrize("normal", [[1, 1, 1], [1, 1, -0.2], [-0.1, 1, 1], [-0.3, -0.2, 1], [0.2, 0.1, 0.9]])
def test_at_a_corner_the_cone_is_the_octant(cube, normal):
    """Closed form: the nearest direction in the positive octant clips the negative components."""
    m = unit(normal)
    expected = np.arccos(np.clip(m @ unit(np.clip(m, 0.0, None)), -1, 1))
    error = MeshProximity(cube).normal_cone_error(np.array([[1.3, 1.2, 1.1]]), m[None])
    assert error[0] == pytest.approx(expected, abs=1e-9)


def test_inside_a_face_it_is_the_angle_to_that_face(cube):
    rng = np.random.default_rng(0)
    points = np.column_stack([np.full(20, 1.4), rng.uniform(-0.8, 0.8, (20, 2))])  # closest points inside +x
    normals = unit(rng.normal(size=(20, 3)))
    expected = np.arccos(np.clip(normals[:, 0], -1, 1))
    np.testing.assert_allclose(MeshProximity(cube).normal_cone_error(points, normals), expected, atol=1e-9)


def test_points_on_an_edge_and_at_a_corner_lie_on_their_faces(cube):
    proximity = MeshProximity(cube)
    points = np.array([[1.0, 0.2, 1.0], [1.0, 1.0, 1.0], [1.0, 0.1, 0.2], [1.0, 0.1, 1.0 - 5e-6], [1.0, 0.1, 0.99]])
    normals = [np.unique(np.round(cube.face_normals[f], 9), axis=0) for f in proximity.faces_at(points, 1e-4)]
    # two faces' normals on the edge, three at the corner, one inside a face; 5e-6 from the edge
    # counts as on it (tolerance 1e-4), 0.01 does not; with no tolerance 5e-6 is off the edge
    assert [len(n) for n in normals] == [2, 3, 1, 2, 1]
    assert len(np.unique(np.round(cube.face_normals[proximity.faces_at(points[3:4])[0]], 9), axis=0)) == 1


def test_a_point_equally_near_two_faces_is_measured_against_the_better_one(cube):
    """Pressed into the solid on the bisector of an edge: neither face is more "the" closest one."""
    proximity = MeshProximity(cube)
    inside = np.array([[0.7, 0.0, 0.7 + 2e-5]])  # 0.3 from both faces, 2e-5 (under the tolerance) nearer the +z one
    assert np.degrees(proximity.normal_cone_error(inside, np.array([[1.0, 0.0, 0.0]])))[0] == pytest.approx(0.0, abs=1e-9)
    assert np.degrees(proximity.normal_cone_error(inside, unit([[1.0, 0.0, 1.0]])))[0] == pytest.approx(45.0, abs=1e-6)
    deeper = np.array([[0.7, 0.0, 0.75]])  # 0.05 nearer the +z face: the +x face is no candidate
    assert np.degrees(proximity.normal_cone_error(deeper, np.array([[1.0, 0.0, 0.0]])))[0] == pytest.approx(90.0, abs=1e-6)


def test_the_far_side_of_a_thin_wall_never_joins_the_cone():
    slab = trimesh.creation.box((0.1, 0.1, 0.004))  # a 4 mm wall
    error = MeshProximity(slab).normal_cone_error(np.array([[0.0, 0.0, 0.0015]]), np.array([[0.0, 0.0, -1.0]]))
    assert np.degrees(error[0]) == pytest.approx(180.0, abs=1e-6)  # 0.5 mm below the top, normal of the bottom


def brute_force_angle(direction, generators, n=200_000, seed=0) -> float:
    """Smallest angle to random non-negative combinations of the generators (and the generators)."""
    weights = np.random.default_rng(seed).exponential(size=(n, len(generators))) ** 3  # reach the boundary
    weights[: len(generators)] = np.eye(len(generators))
    cone = unit(weights @ generators)
    return float(np.arccos(np.clip(cone @ direction, -1, 1)).min())


@pytest.mark.parametrize("seed", range(6))
def test_angle_to_a_cone_matches_a_brute_force_search(seed):
    rng = np.random.default_rng(seed)
    axis = unit(rng.normal(size=3))
    generators = unit(axis + 0.8 * rng.normal(size=(int(rng.integers(2, 5)), 3)))  # a pointed cone
    generators = generators[generators @ axis > 0.2]
    for direction in unit(rng.normal(size=(8, 3))):
        exact = angle_to_cone(direction, generators)
        searched = brute_force_angle(direction, generators)
        assert exact <= searched + 1e-9  # never more than an angle actually reached
        assert searched - exact < np.radians(0.5)


def _every_pair_angle(direction, generators, monkeypatch):
    monkeypatch.setattr(proximity, "PAIRWISE_GENERATORS", 10 ** 6)
    angle = angle_to_cone(direction, generators)
    monkeypatch.undo()
    return angle


@pytest.mark.parametrize("seed", range(4))
def test_a_cone_of_many_generators_cut_to_its_boundary_gives_every_pair_s_angle(seed, monkeypatch):
    rng = np.random.default_rng(seed)
    axis = unit(rng.normal(size=3))
    generators = unit(axis + 0.6 * rng.normal(size=(int(rng.integers(9, 40)), 3)))
    generators = generators[generators @ axis > 0.3]
    assert len(generators) > proximity.PAIRWISE_GENERATORS
    for direction in unit(rng.normal(size=(12, 3))):
        assert angle_to_cone(direction, generators) == pytest.approx(
            _every_pair_angle(direction, generators, monkeypatch), abs=1e-12)


def test_a_fan_of_faces_at_a_pole_and_generators_on_one_great_circle(monkeypatch):
    """384 normals tilted 5 deg round the z axis (a revolved mesh's pole): a direction tilted 12 deg
    towards one of them is 7 deg from the cone; along one great circle only its two ends count."""
    azimuth = np.linspace(0.0, 2 * np.pi, 384, endpoint=False)
    tilt = np.radians(5.0)
    fan = np.column_stack([np.sin(tilt) * np.cos(azimuth), np.sin(tilt) * np.sin(azimuth), np.full(384, np.cos(tilt))])
    direction = np.array([np.sin(np.radians(12.0)), 0.0, np.cos(np.radians(12.0))])
    assert np.degrees(angle_to_cone(direction, fan)) == pytest.approx(7.0, abs=1e-9)
    assert angle_to_cone(np.array([0.0, 0.0, 1.0]), fan) == 0.0
    along = np.radians(np.linspace(-20.0, 30.0, 12))
    arc = np.column_stack([np.sin(along), np.zeros(12), np.cos(along)])
    for direction in unit([[1.0, 0.0, 0.2], [0.3, 0.4, 1.0], [-1.0, 0.1, 1.0]]):
        assert angle_to_cone(direction, arc) == pytest.approx(_every_pair_angle(direction, arc, monkeypatch), abs=1e-12)


def test_contacts_at_a_pole_where_hundreds_of_faces_meet_score_as_with_every_pair(monkeypatch):
    """A UV sphere's poles are fans of 128 faces: near them the points tied for closest and the
    generators are many; one point per place and the cone's boundary give every pair's answer."""
    sphere = trimesh.creation.uv_sphere(radius=0.05, count=[32, 128])
    rng = np.random.default_rng(7)
    points = np.array([[0.0, 0.0, 0.0504], [1e-4, -5e-5, 0.0502], [0.0, 0.0, -0.0503]]) + rng.normal(scale=2e-5, size=(3, 3))
    normals = unit(np.sign(points[:, 2:]) * np.array([0.0, 0.0, 1.0]) + rng.normal(scale=0.2, size=(3, 3)))
    fast = MeshProximity(sphere).normal_cone_error(points, normals)
    monkeypatch.setattr(proximity, "PAIRWISE_GENERATORS", 10 ** 6)
    np.testing.assert_allclose(fast, MeshProximity(sphere).normal_cone_error(points, normals), rtol=0, atol=1e-12)
    assert np.all(fast > 0.0)


def test_on_a_faceted_sphere_the_cone_error_never_exceeds_the_closest_face_error():
    sphere = trimesh.creation.icosphere(subdivisions=2, radius=0.05)
    rng = np.random.default_rng(3)
    points = unit(rng.normal(size=(300, 3))) * rng.uniform(0.048, 0.054, (300, 1))
    normals = unit(points + rng.normal(scale=0.2, size=points.shape) * np.linalg.norm(points, axis=1, keepdims=True))
    proximity = MeshProximity(sphere)
    _, _, face = proximity.query(points)
    closest_face = np.arccos(np.clip(np.sum(normals * sphere.face_normals[face], axis=1), -1, 1))
    cone = proximity.normal_cone_error(points, normals)
    assert np.all(cone <= closest_face + 1e-12)
    assert np.any(cone < closest_face - 1e-6)  # points outside project onto edges and vertices
    # Against the analytic sphere's normal at the point, the cone error is off by at most the
    # turn between neighbouring facets (the faceting), whatever the point.
    facet_angle = np.arccos(np.clip(np.einsum("ij,ij->i", *sphere.face_normals[sphere.face_adjacency.T]), -1, 1)).max()
    analytic = np.arccos(np.clip(np.sum(normals * unit(points), axis=1), -1, 1))
    assert np.all(np.abs(cone - analytic) <= facet_angle + 1e-9)


def test_metrics_charge_a_contact_across_an_edge_nothing_for_a_normal_between_its_faces(cube):
    mesh = cube.copy()
    point = np.array([[1.0005, 0.3, 1.0005]])  # 0.7 mm beside the edge, the pad across it
    errors = reconstruction_errors(mesh, cube, point, unit([[1.0, 0.0, 1.0]]))
    assert errors["contact_normal_error_mean_deg"] == pytest.approx(0.0, abs=1e-9)
    assert errors["contact_normal_error_closest_face_mean_deg"] == pytest.approx(45.0, abs=1e-6)


def test_a_contact_past_the_middle_of_a_thin_wall_is_measured_from_the_face_it_was_on():
    """6 mm wall, a contact measured 4 mm below its top face with the top's normal: the plain
    closest point is the bottom face (2 mm, opposite normal); the pad can only have pressed the top."""
    slab = trimesh.creation.box((0.1, 0.1, 0.006))
    proximity = MeshProximity(slab)
    point, up = np.array([[0.01, 0.02, -0.001]]), np.array([[0.0, 0.1, 1.0]])
    _, plain, _ = proximity.query(point)
    closest, distance, face = proximity.query_facing(point, up)
    assert plain[0] == pytest.approx(0.002, abs=1e-12)
    assert distance[0] == pytest.approx(0.004, abs=1e-12)
    np.testing.assert_allclose(closest[0], [0.01, 0.02, 0.003], atol=1e-12)
    np.testing.assert_allclose(slab.face_normals[face[0]], [0.0, 0.0, 1.0])
    assert np.degrees(proximity.normal_cone_error(point, unit(up))[0]) > 170.0
    assert np.degrees(proximity.normal_cone_error(point, unit(up), facing=True)[0]) == pytest.approx(
        np.degrees(np.arctan(0.1)), abs=1e-9)
    errors = reconstruction_errors(slab.copy(), slab, point, unit(up))
    assert errors["contact_position_error_rms_mm"] == pytest.approx(4.0, abs=1e-9)
    assert errors["contact_normal_error_mean_deg"] == pytest.approx(np.degrees(np.arctan(0.1)), abs=1e-9)


def test_facing_closest_points_match_trimesh_on_the_facing_faces():
    """Independent answer: trimesh's closest point on the sub-mesh of faces within 90 deg of each
    normal; and where the plain closest face already faces the normal, the plain query."""
    ring = trimesh.creation.annulus(r_min=0.028, r_max=0.034, height=0.05, sections=48)
    rng = np.random.default_rng(7)
    on, faces = trimesh.sample.sample_surface(ring, 60, seed=7)
    normals = unit(ring.face_normals[faces] + rng.normal(scale=0.3, size=(60, 3)))
    points = on - ring.face_normals[faces] * rng.uniform(0.0, 0.006, (60, 1))   # up to through the wall
    proximity = MeshProximity(ring)
    plain_closest, plain, plain_face = proximity.query(points)
    closest, distance, face = proximity.query_facing(points, normals)
    moved = 0
    for i in range(60):
        facing = np.flatnonzero(ring.face_normals @ normals[i] > 0)
        sub = ring.submesh([facing], append=True)
        expected, gap, _ = trimesh.proximity.closest_point(sub, points[i][None])
        assert distance[i] == pytest.approx(gap[0], abs=1e-6)         # trimesh comes within 0.5 um
        assert distance[i] <= gap[0] + 1e-12
        assert ring.face_normals[face[i]] @ normals[i] > 0
        if ring.face_normals[plain_face[i]] @ normals[i] > 0:
            assert distance[i] == pytest.approx(plain[i], abs=1e-12)
        else:
            moved += 1
    assert moved > 0                                             # some went past the wall's middle
