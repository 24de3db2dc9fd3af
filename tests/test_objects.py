"""Ground-truth objects: geometry against closed forms, committed files, PyBullet view, user meshes."""
from __future__ import annotations

import subprocess
import sys
import warnings
import xml.etree.ElementTree as ElementTree

import numpy as np
import pybullet
import pytest
import trimesh

import objects
from objects.banana import BananaShape, banana_mesh
from objects.catalogue import DATA_DIR, SPECS, registry_urdf_text, urdf_filename
from objects.generate import write_data
from objects.lofting import loft, revolve
from objects.proximity import MeshProximity, closest_on_triangles
from objects.sampling import sample_surface

REGISTRY = ["box", "sphere", "cylinder", "banana", "bowl", "cereal_box", "coffee_can", "flat"]
TOLERANCE_M = 1e-4  # promised discretisation error bound, 0.1 mm


@pytest.fixture(scope="module")
def models():
    return {name: objects.load(name) for name in objects.names()}


def surface_points(mesh: trimesh.Trimesh, n: int = 20000, seed: int = 0) -> np.ndarray:
    """Random surface points plus face centroids (where an inscribed triangle sags most)."""
    points, _ = sample_surface(mesh, n, np.random.default_rng(seed))
    return np.vstack([points, mesh.triangles_center])


# --- registry ---------------------------------------------------------------------------------

def test_registry_lists_the_reference_and_extra_objects():
    assert list(objects.names()) == REGISTRY


@pytest.mark.parametrize("name", REGISTRY)
def test_registry_object_is_a_closed_outward_surface_of_modest_size(models, name):
    model = models[name]
    mesh = model.mesh
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert mesh.volume > 0  # outward normals
    assert mesh.euler_number == 2  # one closed sphere-like surface
    assert len(mesh.faces) <= 7500
    np.testing.assert_allclose(model.centre_m, 0.0, atol=TOLERANCE_M)
    np.testing.assert_allclose(model.extent_m, mesh.extents)
    assert model.name == name and model.description
    assert model.urdf_path.is_file() and model.mesh_path.is_file()


EXPECTED_EXTENT_M = {
    "box": (0.10, 0.07, 0.05), "sphere": (0.10, 0.10, 0.10), "cylinder": (0.08, 0.08, 0.12),
    "bowl": (0.16, 0.16, 0.082), "cereal_box": (0.06, 0.16, 0.21), "coffee_can": (0.10, 0.10, 0.14),
    "flat": (0.20, 0.20, 0.01),
}


@pytest.mark.parametrize("name", sorted(EXPECTED_EXTENT_M))
def test_bounding_box_matches_the_documented_size(models, name):
    # Inscribed tessellations may fall short of the analytic box by the chord error only.
    extent = models[name].extent_m
    assert np.all(extent <= np.array(EXPECTED_EXTENT_M[name]) + 1e-9)
    assert np.all(extent >= np.array(EXPECTED_EXTENT_M[name]) - 2 * TOLERANCE_M)


def test_boxes_have_exact_volume(models):
    for name in ("box", "cereal_box", "flat"):
        assert models[name].mesh.volume == pytest.approx(np.prod(EXPECTED_EXTENT_M[name]), rel=1e-12)


# --- discretisation error against the analytic shapes -----------------------------------------

def analytic_sample_distance(mesh: trimesh.Trimesh, analytic_points: np.ndarray) -> np.ndarray:
    return MeshProximity(mesh).query(analytic_points)[1]


def test_sphere_within_tolerance_of_analytic_sphere(models):
    mesh, radius = models["sphere"].mesh, 0.05
    np.testing.assert_allclose(np.linalg.norm(mesh.vertices, axis=1), radius, atol=2e-9)
    mesh_to_shape = np.abs(np.linalg.norm(surface_points(mesh), axis=1) - radius)
    assert mesh_to_shape.max() < TOLERANCE_M
    directions = np.random.default_rng(1).normal(size=(5000, 3))
    on_sphere = radius * directions / np.linalg.norm(directions, axis=1, keepdims=True)
    assert analytic_sample_distance(mesh, on_sphere).max() < TOLERANCE_M


def cylinder_distance(points: np.ndarray, radius: float, height: float) -> np.ndarray:
    """Exact unsigned distance to the surface of a closed cylinder about z centred at the origin."""
    radial = np.linalg.norm(points[:, :2], axis=1) - radius
    axial = np.abs(points[:, 2]) - height / 2
    outside = np.hypot(np.maximum(radial, 0), np.maximum(axial, 0))
    return np.where((radial <= 0) & (axial <= 0), -np.maximum(radial, axial), outside)


def cylinder_surface_points(radius: float, height: float, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    side_area, cap_area = 2 * np.pi * radius * height, np.pi * radius**2
    on_side = rng.random(n) < side_area / (side_area + 2 * cap_area)
    angle = rng.uniform(0, 2 * np.pi, n)
    rho = np.where(on_side, radius, radius * np.sqrt(rng.random(n)))
    z = np.where(on_side, rng.uniform(-height / 2, height / 2, n), np.sign(rng.random(n) - 0.5) * height / 2)
    return np.column_stack([rho * np.cos(angle), rho * np.sin(angle), z])


@pytest.mark.parametrize("name, radius, height", [("cylinder", 0.04, 0.12), ("coffee_can", 0.05, 0.14)])
def test_cylinders_within_tolerance_of_analytic_cylinder(models, name, radius, height):
    mesh = models[name].mesh
    assert cylinder_distance(np.asarray(mesh.vertices), radius, height).max() < 2e-9
    assert cylinder_distance(surface_points(mesh), radius, height).max() < TOLERANCE_M
    on_shape = cylinder_surface_points(radius, height, 5000, seed=2)
    assert analytic_sample_distance(mesh, on_shape).max() < TOLERANCE_M
    assert mesh.is_convex


def distance_to_arc(q: np.ndarray, centre: tuple[float, float], radius: float, start: float, stop: float) -> np.ndarray:
    """Distance from 2-D points to the circular arc of angles [start, stop] (radians)."""
    offset = q - np.asarray(centre)
    angle = np.arctan2(offset[:, 1], offset[:, 0])
    within = (angle >= start) & (angle <= stop)
    ends = np.asarray(centre) + radius * np.array([[np.cos(start), np.sin(start)], [np.cos(stop), np.sin(stop)]])
    to_ends = np.min(np.linalg.norm(q[:, None] - ends[None], axis=2), axis=1)
    return np.where(within, np.abs(np.linalg.norm(offset, axis=1) - radius), to_ends)


def bowl_distance(points: np.ndarray) -> np.ndarray:
    """Exact distance to the bowl: distance in the (radius, z) half-plane to its profile arcs."""
    outer, wall = 0.08, 0.004
    z_shift = (outer - wall / 2) / 2  # the registry bowl is centred on its bounding box
    q = np.column_stack([np.linalg.norm(points[:, :2], axis=1), points[:, 2] - z_shift])
    return np.minimum.reduce([
        distance_to_arc(q, (0.0, 0.0), outer, -np.pi / 2, 0.0),
        distance_to_arc(q, (0.0, 0.0), outer - wall, -np.pi / 2, 0.0),
        distance_to_arc(q, (outer - wall / 2, 0.0), wall / 2, 0.0, np.pi),
    ])


def test_bowl_within_tolerance_of_analytic_bowl(models):
    mesh = models["bowl"].mesh
    assert bowl_distance(np.asarray(mesh.vertices)).max() < 2e-9
    assert bowl_distance(surface_points(mesh)).max() < TOLERANCE_M
    assert not mesh.is_convex
    # Wall volume: hemispherical shell plus the upper half of a torus (Pappus: the half disc's
    # centroid sits above the rim circle, so it travels 2 pi 78 mm).
    outer, inner, tube = 0.08, 0.076, 0.002
    expected = 2 / 3 * np.pi * (outer**3 - inner**3) + np.pi * tube**2 / 2 * 2 * np.pi * 0.078
    assert mesh.volume == pytest.approx(expected, rel=0.01)


def test_banana_within_tolerance_of_swept_spheres_and_banana_sized(models):
    shape = BananaShape()
    raw = banana_mesh(shape, tolerance_m=7e-5, max_step_m=0.005)
    offset = raw.bounds.mean(axis=0)  # the registry banana is centred on its bounding box
    mesh = models["banana"].mesh
    np.testing.assert_allclose(mesh.vertices, raw.vertices - offset, atol=1e-9)
    assert np.abs(shape.signed_distance(np.asarray(raw.vertices))).max() < 1e-6
    assert np.abs(shape.signed_distance(surface_points(raw, n=5000))).max() < TOLERANCE_M

    spine = np.linspace(0, shape.spine_length_m, 2001)
    assert 2 * shape.radius(spine).max() == pytest.approx(0.035, abs=0.001)
    assert mesh.extents[2] == pytest.approx(2 * shape.radius(spine).max(), abs=TOLERANCE_M)
    tip_to_tip = shape.spine_length_m + shape.stem_radius_m + shape.tip_radius_m
    assert tip_to_tip == pytest.approx(0.18, abs=0.005)
    # Volume ~ integral of the cross-section area along the spine (Pappus for a thin bent tube)
    # plus the two end hemispheres.
    tube = np.trapezoid(np.pi * shape.radius(spine) ** 2, spine)
    caps = 2 / 3 * np.pi * (shape.stem_radius_m**3 + shape.tip_radius_m**3)
    assert mesh.volume == pytest.approx(tube + caps, rel=0.02)
    assert not mesh.is_convex


# --- sharp edges ------------------------------------------------------------------------------

@pytest.mark.parametrize("name", ["box", "cereal_box", "flat"])
def test_box_sharp_edges_are_its_twelve_edges(models, name):
    edges = models[name].sharp_edges
    half = np.array(EXPECTED_EXTENT_M[name]) / 2
    total = np.linalg.norm(edges[:, 1] - edges[:, 0], axis=1).sum()
    assert total == pytest.approx(4 * 2 * half.sum(), rel=1e-12)
    on_limits = np.isclose(np.abs(edges), half, atol=1e-12).sum(axis=2)
    assert np.all(on_limits >= 2)  # every end point lies on a box edge line


@pytest.mark.parametrize("name, radius, height", [("cylinder", 0.04, 0.12), ("coffee_can", 0.05, 0.14)])
def test_cylinder_sharp_edges_are_its_two_rims(models, name, radius, height):
    edges = models[name].sharp_edges
    np.testing.assert_allclose(np.linalg.norm(edges[..., :2], axis=2), radius, atol=1e-9)
    np.testing.assert_allclose(np.abs(edges[..., 2]), height / 2, atol=1e-9)
    total = np.linalg.norm(edges[:, 1] - edges[:, 0], axis=1).sum()
    assert total == pytest.approx(2 * 2 * np.pi * radius, rel=1e-3)


@pytest.mark.parametrize("name", ["sphere", "banana", "bowl"])
def test_smooth_objects_have_no_sharp_edges(models, name):
    assert models[name].sharp_edges.shape == (0, 2, 3)


@pytest.mark.parametrize("sections, vertical_edges", [(8, 8), (16, 0)])
def test_sharp_edge_threshold_is_thirty_degrees(sections, vertical_edges):
    # A prism with n sides bends 360/n degrees between sides: 45 (sharp) or 22.5 (smooth).
    prism = trimesh.creation.cylinder(radius=0.05, height=0.1, sections=sections)
    edges = objects.sharp_edges(prism)
    vertical = np.abs(edges[:, 0, 2] - edges[:, 1, 2]) > 1e-9
    assert vertical.sum() == vertical_edges
    assert (~vertical).sum() == 2 * sections  # the two rims are always sharp (90 degrees)


# --- committed files --------------------------------------------------------------------------

@pytest.mark.parametrize("name", REGISTRY)
def test_committed_files_match_the_generators(models, name):
    built = SPECS[name].build()
    committed = models[name].mesh
    np.testing.assert_array_equal(committed.faces, built.faces)
    np.testing.assert_allclose(committed.vertices, built.vertices, rtol=0, atol=1e-9)
    assert (DATA_DIR / urdf_filename(name)).read_text() == registry_urdf_text(name)


def test_write_data_writes_obj_and_urdf_pairs(tmp_path):
    written = write_data(tmp_path, ["box"])
    assert sorted(p.name for p in written) == ["box.obj", "box.urdf"]
    rewritten = trimesh.load(tmp_path / "box.obj", force="mesh", process=False)
    np.testing.assert_allclose(rewritten.vertices, SPECS["box"].build().vertices, atol=1e-9)


@pytest.mark.parametrize("name", REGISTRY)
def test_urdf_is_a_static_link_with_exact_mesh_collision(models, name):
    model = models[name]
    link = ElementTree.parse(model.urdf_path).getroot().find("link")
    assert float(link.find("inertial/mass").get("value")) == 0.0
    assert link.get("concave") == "yes" and link.find("collision").get("concave") == "yes"
    for part in ("visual", "collision"):
        mesh = link.find(f"{part}/geometry/mesh")
        assert (model.urdf_path.parent / mesh.get("filename")).resolve() == model.mesh_path.resolve()
        assert mesh.get("scale") == "1 1 1"


def test_pybullet_sees_the_same_surface(models):
    """Probe spheres near each object: PyBullet's distance equals the mesh distance (same frame,
    scale and exact triangle collision, no convex-hull margin)."""
    client = pybullet.connect(pybullet.DIRECT)
    try:
        probe_radius = 0.002
        probe_shape = pybullet.createCollisionShape(pybullet.GEOM_SPHERE, radius=probe_radius, physicsClientId=client)
        rng = np.random.default_rng(4)
        for name, model in models.items():
            body = pybullet.loadURDF(str(model.urdf_path), physicsClientId=client)
            points, faces = sample_surface(model.mesh, 10, rng)
            probes = points + model.mesh.face_normals[faces] * rng.uniform(0.004, 0.02, (10, 1))
            _, expected, _ = MeshProximity(model.mesh).query(probes)
            for probe, distance in zip(probes, expected):
                marker = pybullet.createMultiBody(0, probe_shape, basePosition=probe.tolist(), physicsClientId=client)
                contacts = pybullet.getClosestPoints(body, marker, 0.1, physicsClientId=client)
                measured = min(c[8] for c in contacts) + probe_radius
                assert measured == pytest.approx(distance, abs=1e-5), name
                pybullet.removeBody(marker, physicsClientId=client)
            pybullet.removeBody(body, physicsClientId=client)
    finally:
        pybullet.disconnect(client)


def test_objects_package_does_not_import_pybullet():
    code = "import sys, objects; objects.load('bowl'); print('pybullet' in sys.modules)"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert result.stdout.strip() == "False"


# --- loading user meshes ----------------------------------------------------------------------

def icosphere(radius: float = 0.03) -> trimesh.Trimesh:
    return trimesh.creation.icosphere(subdivisions=2, radius=radius)


@pytest.mark.parametrize("suffix", [".obj", ".stl", ".ply", ".off", ".glb"])
def test_user_mesh_round_trip_writes_a_cached_urdf(tmp_path, suffix):
    source = icosphere()
    path = tmp_path / f"ball{suffix}"
    source.export(path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a clean mesh needs no repair
        model = objects.load(path, cache_dir=tmp_path / "cache")
    assert model.name == "ball"
    assert model.mesh.volume == pytest.approx(source.volume, rel=1e-6)
    assert model.urdf_path.is_file() and model.urdf_path.is_relative_to(tmp_path / "cache")
    reread = trimesh.load(model.mesh_path, force="mesh")
    assert reread.volume == pytest.approx(source.volume, rel=1e-6)
    assert objects.load(path, cache_dir=tmp_path / "cache").urdf_path == model.urdf_path  # deterministic


def test_user_mesh_in_millimetres_needs_scale(tmp_path):
    path = tmp_path / "part.stl"
    trimesh.creation.box(extents=(120.0, 80.0, 60.0)).export(path)
    with pytest.raises(ValueError, match=r"millimetres: pass --units mm \(scale=0\.001"):
        objects.load(path, cache_dir=tmp_path)
    model = objects.load(path, scale=0.001, cache_dir=tmp_path)
    np.testing.assert_allclose(model.extent_m, [0.12, 0.08, 0.06])
    assert model.sharp_edges.shape == (12, 2, 3)


def test_user_mesh_with_a_hole_is_filled_with_a_warning(tmp_path):
    source = icosphere()
    holed = trimesh.Trimesh(source.vertices, source.faces[1:], process=False)
    path = tmp_path / "holed.obj"
    holed.export(path)
    with pytest.warns(UserWarning, match="filled holes"):
        model = objects.load(path, cache_dir=tmp_path)
    assert model.mesh.is_watertight
    assert model.mesh.volume == pytest.approx(source.volume, rel=1e-6)  # OBJ/PLY keep ~8 digits


def test_user_mesh_inside_out_is_inverted_with_a_warning(tmp_path):
    source = icosphere()
    path = tmp_path / "inverted.ply"
    trimesh.Trimesh(source.vertices, source.faces[:, ::-1], process=False).export(path)
    with pytest.warns(UserWarning, match="normals point outward"):
        model = objects.load(path, cache_dir=tmp_path)
    assert model.mesh.volume == pytest.approx(source.volume, rel=1e-6)  # OBJ/PLY keep ~8 digits


def test_an_open_shell_is_refused_not_closed(tmp_path):
    """A hemispherical shell closed by its winding number would be a third made-up disc: refused."""
    source = icosphere()
    half = trimesh.Trimesh(source.vertices, source.faces[source.triangles_center[:, 2] > 0], process=False)
    path = tmp_path / "cup.obj"
    half.export(path)
    with pytest.raises(ValueError, match=r"cup\.obj: the surface is open.*3\d % of the surface would span "
                                         r"openings.*open shell.*thickness"):
        objects.load(path, cache_dir=tmp_path)


def test_a_scan_with_a_large_hole_is_closed_with_a_warning_and_cached(tmp_path, monkeypatch):
    """A sphere with a 20 deg cap cut away (more than trimesh's hole filling closes) loads closed; a
    second load reads the closed mesh back from the cache instead of closing it again."""
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=0.02)
    cut = sphere.triangles_center[:, 2] > 0.02 * np.cos(np.radians(20.0))
    path = tmp_path / "scan.ply"
    trimesh.Trimesh(sphere.vertices, sphere.faces[~cut], process=False).export(path)
    with pytest.warns(UserWarning, match=r"scan\.ply: repaired mesh: the surface is open.*generalized winding "
                                         r"number.*[1-4]\.\d % of the surface spans holes"):
        model = objects.load(path, cache_dir=tmp_path / "cache")
    assert model.mesh.is_watertight and model.mesh.body_count == 1 and model.mesh.volume > 0
    np.testing.assert_allclose(model.extent_m[:2], 0.04, atol=5e-4)
    monkeypatch.setattr("objects.loading.close_surface", lambda mesh: pytest.fail("closed again"))
    with pytest.warns(UserWarning, match="spans holes"):
        again = objects.load(path, cache_dir=tmp_path / "cache")
    np.testing.assert_array_equal(again.mesh.vertices, model.mesh.vertices)
    np.testing.assert_array_equal(again.mesh.faces, model.mesh.faces)
    with warnings.catch_warnings():  # the cleaned copy (what --units hands on) needs nothing more
        warnings.simplefilter("error")
        copy = objects.load(model.mesh_path, cache_dir=tmp_path / "cache")
    np.testing.assert_allclose(copy.mesh.vertices, model.mesh.vertices, atol=1e-8)
    np.testing.assert_array_equal(copy.mesh.faces, model.mesh.faces)


def test_a_mesh_far_from_its_origin_is_centred_with_a_warning_and_a_near_one_is_kept(tmp_path):
    """The stand turns an object about its origin: a CAD part drawn from its corner is moved so that
    the centre of its bounding box is the origin, and the warning gives the shift back to the file."""
    box = trimesh.creation.box(extents=(0.12, 0.08, 0.06))
    box.apply_translation([0.1, -0.05, 0.2])
    box.export(tmp_path / "corner.stl")
    with pytest.warns(UserWarning, match=r"corner\.stl: the centre of its bounding box lies 229 mm from its "
                                         r"origin.*\+ \(100\.0, -50\.0, 200\.0\) mm"):
        model = objects.load(tmp_path / "corner.stl", cache_dir=tmp_path / "cache")
    np.testing.assert_allclose(model.mesh.bounds, [[-0.06, -0.04, -0.03], [0.06, 0.04, 0.03]], atol=1e-9)
    np.testing.assert_allclose(model.centre_m, 0.0, atol=1e-9)
    np.testing.assert_allclose(model.file_shift_m, [0.1, -0.05, 0.2], atol=1e-12)
    written = trimesh.load(model.mesh_path, force="mesh")  # what the simulator loads
    np.testing.assert_allclose(written.bounds, model.mesh.bounds, atol=1e-8)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        own_frame = objects.load(tmp_path / "corner.stl", cache_dir=tmp_path / "cache", keep_frame=True)
    np.testing.assert_allclose(own_frame.centre_m, [0.1, -0.05, 0.2], atol=1e-9)
    np.testing.assert_array_equal(own_frame.file_shift_m, 0.0)
    np.testing.assert_allclose(trimesh.load(own_frame.mesh_path, force="mesh").bounds, own_frame.mesh.bounds, atol=1e-8)

    near = trimesh.creation.box(extents=(0.12, 0.08, 0.06))
    near.apply_translation([0.0005, 0.0, -0.0005])
    near.export(tmp_path / "near.stl")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        kept = objects.load(tmp_path / "near.stl", cache_dir=tmp_path / "cache")
    np.testing.assert_allclose(kept.centre_m, [0.0005, 0.0, -0.0005], atol=1e-9)
    np.testing.assert_array_equal(kept.file_shift_m, 0.0)

    in_mm = trimesh.creation.box(extents=(120.0, 80.0, 60.0))
    in_mm.apply_translation([100.0, -50.0, 200.0])
    in_mm.export(tmp_path / "corner_mm.stl")
    copy = objects.in_metres(tmp_path / "corner_mm.stl", "mm", cache_dir=tmp_path / "cache")
    with pytest.warns(UserWarning, match=r"\+ \(100\.0, -50\.0, 200\.0\) mm"):  # the copy is centred as the file
        np.testing.assert_allclose(objects.load(copy, cache_dir=tmp_path / "cache").file_shift_m,
                                   [0.1, -0.05, 0.2], atol=1e-9)


def test_bad_names_and_files_get_clear_errors(tmp_path):
    with pytest.raises(ValueError, match="unknown object 'bananna'.*box, sphere"):
        objects.load("bananna")
    with pytest.raises(FileNotFoundError, match="missing.obj"):
        objects.load(tmp_path / "missing.obj")
    (tmp_path / "notes.txt").write_text("a box")
    with pytest.raises(ValueError, match="unsupported mesh file type '.txt'"):
        objects.load(tmp_path / "notes.txt")
    (tmp_path / "empty.obj").write_text("# nothing here\n")
    with pytest.raises(ValueError, match="empty.obj.*no triangles"):
        objects.load(tmp_path / "empty.obj", cache_dir=tmp_path)
    (tmp_path / "noise.stl").write_bytes(b"\x00\x01garbage" * 7)
    with pytest.raises(ValueError, match="noise.stl"):
        objects.load(tmp_path / "noise.stl", cache_dir=tmp_path)
    with pytest.raises(ValueError, match="scale applies to mesh files only"):
        objects.load("box", scale=0.001)
    icosphere().export(tmp_path / "ball.obj")
    with pytest.raises(ValueError, match="scale must be a positive"):
        objects.load(tmp_path / "ball.obj", scale=-1.0, cache_dir=tmp_path)


def test_loads_return_independent_meshes():
    first, second = objects.load("box"), objects.load("box")
    first.mesh.apply_translation([1.0, 0.0, 0.0])
    np.testing.assert_allclose(second.mesh.bounds.mean(axis=0), 0.0, atol=1e-12)


# --- meshing and proximity building blocks -----------------------------------------------------

def test_loft_stitches_rings_of_any_counts_into_a_closed_surface():
    heights = np.array([-0.02, -0.01, 0.0, 0.01, 0.02])
    radii = np.sqrt(0.03**2 - heights**2)
    counts = [6, 13, 7, 31, 5]
    m = len(radii)
    mesh = loft(np.column_stack([np.zeros(m), np.zeros(m), heights]), np.tile([1.0, 0, 0], (m, 1)),
                np.tile([0, 1.0, 0], (m, 1)), radii, counts, [0, 0, -0.03], [0, 0, 0.03])
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
    assert len(mesh.faces) == 2 * (sum(counts) + 2) - 4  # Euler: F = 2V - 4 for a closed sphere


def test_revolve_rejects_profiles_off_the_axis():
    with pytest.raises(ValueError, match="start and end on the axis"):
        revolve(np.array([[0.01, 0.0], [0.02, 0.01], [0.0, 0.02]]), 0.005)


def test_closest_on_triangles_matches_closed_forms():
    a, b, c = np.array([0.0, 0, 0]), np.array([1.0, 0, 0]), np.array([0.0, 1, 0])
    points = np.array([[0.2, 0.2, 0.5],    # above the face: foot of the perpendicular
                       [-1.0, -1.0, 0.0],  # beyond vertex a
                       [0.5, -2.0, 1.0],   # beyond edge ab
                       [1.0, 1.0, 0.0],    # beyond edge bc
                       [3.0, -0.5, 0.0]])  # beyond vertex b
    expected = np.array([[0.2, 0.2, 0], [0, 0, 0], [0.5, 0, 0], [0.5, 0.5, 0], [1, 0, 0]])
    n = len(points)
    got = closest_on_triangles(points, np.tile(a, (n, 1)), np.tile(b, (n, 1)), np.tile(c, (n, 1)))
    np.testing.assert_allclose(got, expected, atol=1e-15)


def test_mesh_proximity_equals_brute_force_over_all_faces(models):
    mesh = models["bowl"].mesh
    rng = np.random.default_rng(5)
    near, _ = sample_surface(mesh, 100, rng)
    queries = np.vstack([near + rng.normal(scale=0.002, size=near.shape),
                         rng.uniform(-0.12, 0.12, size=(50, 3)),
                         [[0.0, 0.0, 0.0]]])  # inside the bowl, far from everything
    closest, distance, face = MeshProximity(mesh).query(queries)
    triangles = np.asarray(mesh.triangles)
    for q, d, f, p in zip(queries, distance, face, closest):
        everywhere = trimesh.triangles.closest_point(triangles, np.tile(q, (len(triangles), 1)))
        assert d == pytest.approx(np.linalg.norm(everywhere - q, axis=1).min(), abs=1e-12)
        np.testing.assert_allclose(p, everywhere[f], atol=1e-12)


def test_mesh_proximity_skips_zero_area_faces_and_names_faces_of_the_original_mesh():
    # A unit square (two triangles) with a zero-area sliver first: the answers name faces 1 and 2.
    vertices = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0, 0]])
    faces = np.array([[0, 4, 1], [0, 1, 2], [0, 2, 3]])
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    closest, distance, face = MeshProximity(mesh).query(np.array([[0.9, 0.2, 0.3], [0.1, 0.8, -0.4], [2.0, 0.5, 0.0]]))
    np.testing.assert_allclose(closest, [[0.9, 0.2, 0.0], [0.1, 0.8, 0.0], [1.0, 0.5, 0.0]], atol=1e-15)
    np.testing.assert_allclose(distance, [0.3, 0.4, 1.0], atol=1e-15)
    np.testing.assert_array_equal(face[:2], [1, 2])
    assert face[2] == 1   # the square's right edge belongs to face 1 only
    empty = MeshProximity(mesh).query(np.zeros((0, 3)))
    assert [a.shape for a in empty] == [(0, 3), (0,), (0,)]


def test_the_proximity_benchmark_refuses_a_bad_budget_with_one_line(capsys):
    from scripts.proximity_benchmark import main

    with pytest.raises(SystemExit) as stop:
        main(["--points", "0"])
    assert stop.value.code == 2
    assert "--points and --repeats must be >= 1" in capsys.readouterr().err
