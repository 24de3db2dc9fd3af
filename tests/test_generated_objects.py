"""Generated objects (objects.generated) and the user-mesh checks that came with them: parts merged by a
boolean union, a mesh in the wrong unit refused with the --units flag named, and that flag."""
from __future__ import annotations

import warnings

import numpy as np
import pytest
import trimesh

import objects
import objects.generated as generated
from objects.proximity import MeshProximity

SPLITS = generated.TUNING + generated.HELD_OUT


@pytest.fixture(scope="module")
def meshes():
    """Every split shape, built once: name -> mesh."""
    return {name: generated.build_mesh(*generated.parse_name(name)) for name in SPLITS}


# --- the shapes ---------------------------------------------------------------------------------

@pytest.mark.parametrize("name", SPLITS)
def test_every_split_shape_is_one_closed_hand_held_body(meshes, name):
    mesh = meshes[name]
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert mesh.body_count == 1
    assert mesh.volume > 0
    assert 0.06 <= float(np.max(mesh.extents)) <= 0.20
    np.testing.assert_allclose(mesh.bounds.mean(axis=0), 0.0, atol=1e-9)  # origin: bounding-box centre
    assert 300 <= len(mesh.faces) <= 25_000  # moderate resolution


def test_a_name_always_builds_the_same_shape_and_seeds_differ(meshes):
    again = generated.build_mesh("mug", 0)
    np.testing.assert_array_equal(again.vertices, meshes["generated:mug/0"].vertices)
    np.testing.assert_array_equal(again.faces, meshes["generated:mug/0"].faces)
    assert generated.parameters("blob", 7) == generated.parameters("blob", 7)
    for family, seeds in generated.TUNING_SEEDS.items():
        first, second = (meshes[generated.object_name(family, s)] for s in seeds[:2])
        assert generated.parameters(family, seeds[0]) != generated.parameters(family, seeds[1])
        assert first.vertices.shape != second.vertices.shape or not np.allclose(first.vertices, second.vertices)


def test_parameters_stay_in_their_documented_ranges():
    for family in generated.FAMILIES.values():
        for seed in (0, 1, 1000, 12345):
            params = generated.parameters(family.name, seed)
            for key, rule in family.ranges.items():
                if isinstance(rule, generated.Uniform):
                    assert rule.low <= params[key] <= rule.high
                else:
                    assert params[key] in rule.options


def test_the_splits_are_fixed_disjoint_and_equally_varied():
    assert len(generated.TUNING) >= 24 and len(generated.HELD_OUT) >= 24
    assert not set(generated.TUNING) & set(generated.HELD_OUT)
    assert len(set(generated.TUNING)) == len(generated.TUNING)
    assert generated.TUNING[0] == "generated:mug/0" and generated.HELD_OUT[0] == "generated:mug/1000"
    for split in (generated.TUNING, generated.HELD_OUT):
        families = [generated.parse_name(name)[0] for name in split]
        assert sorted(set(families)) == sorted(generated.FAMILIES)
        assert all(families.count(f) >= 2 for f in generated.FAMILIES)
    for family, key in generated.VARIANT_KEYS.items():
        def variants(seeds):
            return sorted(str(generated.parameters(family, seed)[key]) for seed in seeds)
        assert variants(generated.TUNING_SEEDS[family]) == variants(generated.HELD_OUT_SEEDS[family])
    assert len({generated.parameters("fruit", s)["kind"] for s in generated.TUNING_SEEDS["fruit"]}) == 3


def test_concave_families_are_concave(meshes):
    """A mug, bowl, tray or torus is far from its convex hull (the hull would fill the cavity)."""
    for name in ("generated:mug/0", "generated:bowl/0", "generated:tray/1000", "generated:torus/1001"):
        mesh = meshes[name]
        assert mesh.volume < 0.8 * mesh.convex_hull.volume, name


def test_the_readme_table_is_the_families_table():
    from pathlib import Path

    from objects.generated.__main__ import family_table

    readme = (Path(objects.__file__).parent / "README.md").read_text()
    assert family_table() in readme, "regenerate the table with python -m objects.generated"


# --- names ---------------------------------------------------------------------------------------

def test_the_name_syntax_parses():
    assert generated.parse_name("generated:l_tool/17") == ("l_tool", 17)
    assert generated.object_name("mug", 3) == "generated:mug/3"
    assert objects.file_label("generated:mug/3") == "generated-mug-3"


@pytest.mark.parametrize("bad", ["generated:mug", "generated:mug/", "generated:mug/-1", "generated:mug/x",
                                 "generated:/3", "generated:mug/3/4"])
def test_malformed_names_show_the_syntax(bad):
    with pytest.raises(ValueError, match=r"expected generated:FAMILY/SEED.*e\.g\. generated:mug/3"):
        objects.load(bad)


def test_an_unknown_family_lists_the_families():
    with pytest.raises(ValueError, match=r"unknown generated family 'cup'.*families: mug, bowl, tray"):
        objects.load("generated:cup/3")


def test_scale_is_refused_for_generated_names():
    with pytest.raises(ValueError, match="mesh files only"):
        objects.load("generated:mug/3", scale=0.001)
    with pytest.raises(ValueError, match="--units mm applies to mesh files only"):
        objects.in_metres("generated:mug/3", "mm")


# --- loading and the simulation ------------------------------------------------------------------

def test_a_generated_object_loads_like_a_registry_object(tmp_path, meshes):
    model = objects.load("generated:mug/0", cache_dir=tmp_path)
    assert model.name == "generated:mug/0"
    assert model.description.startswith("generated mug (seed 0)")
    assert model.urdf_path.is_file() and model.urdf_path.is_relative_to(tmp_path)
    np.testing.assert_allclose(model.mesh.vertices, meshes["generated:mug/0"].vertices)
    np.testing.assert_allclose(model.extent_m, meshes["generated:mug/0"].extents)
    on_disk = trimesh.load(model.mesh_path, force="mesh", process=False)
    np.testing.assert_allclose(on_disk.vertices, model.mesh.vertices, atol=1e-9)
    stamp = model.mesh_path.stat().st_mtime_ns
    assert objects.load("generated:mug/0", cache_dir=tmp_path).mesh_path.stat().st_mtime_ns == stamp  # not rewritten


def test_pybullet_collides_with_the_exact_concave_surface(tmp_path):
    """The mug loads into the simulated world; PyBullet's distances to it, probed inside the cup, in
    the handle's opening and outside, match the mesh (a convex hull would put them all at 0)."""
    from robots.sim_world import SimWorld

    import pybullet

    model = objects.load("generated:mug/0", cache_dir=tmp_path)
    lo, hi = model.mesh.bounds
    probes = np.array([[-0.01, 0.0, hi[2] - 0.01],                       # inside the cup, below the rim
                       [hi[0] - 0.02, 0.0, 0.0],                          # in the handle's opening
                       [0.0, hi[1] + 0.02, 0.0]])                         # outside
    truth = MeshProximity(model.mesh).query(probes)[1]
    assert np.all(truth > 0.003)
    world = SimWorld(gui=False)
    try:
        body = world.load_urdf(model.urdf_path, (0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0))
        client = world.client
        probe_shape = pybullet.createCollisionShape(pybullet.GEOM_SPHERE, radius=1e-4, physicsClientId=client)
        for point, expected in zip(probes, truth):
            marker = pybullet.createMultiBody(0, probe_shape, basePosition=point.tolist(), physicsClientId=client)
            contacts = pybullet.getClosestPoints(body, marker, 0.2, physicsClientId=client)
            pybullet.removeBody(marker, physicsClientId=client)
            assert contacts, point
            assert min(c[8] for c in contacts) + 1e-4 == pytest.approx(expected, abs=2e-4)
    finally:
        world.close()


# --- user meshes: parts and units ----------------------------------------------------------------

def _overlap(a_min, a_max, b_min, b_max) -> float:
    return float(np.prod(np.clip(np.minimum(a_max, b_max) - np.maximum(a_min, b_min), 0, None)))


@pytest.mark.filterwarnings("ignore:.*moved the origin there:UserWarning")  # the parts sit off the origin
def test_two_overlapping_parts_are_merged_into_their_union_with_a_warning(tmp_path):
    size_a, size_b = np.array([0.10, 0.08, 0.06]), np.array([0.06, 0.10, 0.04])
    shift = np.array([0.05, 0.03, 0.02])
    a = trimesh.creation.box(extents=size_a)
    b = trimesh.creation.box(extents=size_b)
    b.apply_translation(shift)
    path = tmp_path / "decomposition.obj"
    trimesh.util.concatenate([a, b]).export(path)
    expected = (np.prod(size_a) + np.prod(size_b)
                - _overlap(-size_a / 2, size_a / 2, shift - size_b / 2, shift + size_b / 2))
    with pytest.warns(UserWarning, match=r"merged 2 overlapping or touching parts into their outer surface"):
        model = objects.load(path, cache_dir=tmp_path / "cache")
    assert model.mesh.is_watertight and model.mesh.body_count == 1
    assert model.mesh.volume == pytest.approx(expected, rel=1e-6)
    assert model.mesh.volume < np.prod(size_a) + np.prod(size_b)  # the internal faces are gone
    union_bounds = np.array([np.minimum(-size_a / 2, shift - size_b / 2), np.maximum(size_a / 2, shift + size_b / 2)])
    np.testing.assert_allclose(model.mesh.bounds, union_bounds - union_bounds.mean(axis=0), atol=1e-6)  # centred


@pytest.mark.filterwarnings("ignore:.*moved the origin there:UserWarning")  # the parts sit off the origin
def test_parts_that_do_not_touch_are_kept_apart_and_the_warning_says_so(tmp_path):
    a = trimesh.creation.box(extents=(0.06, 0.06, 0.06))
    b = trimesh.creation.box(extents=(0.04, 0.04, 0.04))
    b.apply_translation([0.1, 0.0, 0.0])
    c = trimesh.creation.box(extents=(0.04, 0.04, 0.04))
    c.apply_translation([0.1, 0.02, 0.0])                       # overlaps b, not a
    path = tmp_path / "scene.stl"
    trimesh.util.concatenate([a, b]).export(path)
    with pytest.warns(UserWarning, match=r"its 2 parts do not touch one another; .* 2 separate pieces"):
        model = objects.load(path, cache_dir=tmp_path / "cache")
    assert model.mesh.body_count == 2
    assert model.mesh.volume == pytest.approx(0.06**3 + 0.04**3, rel=1e-6)
    trimesh.util.concatenate([a, b, c]).export(path)
    with pytest.warns(UserWarning, match=r"merged 3 overlapping or touching parts .*; 2 separate pieces remain"):
        model = objects.load(path, cache_dir=tmp_path / "cache")
    assert model.mesh.body_count == 2

@pytest.mark.filterwarnings("ignore:.*moved the origin there:UserWarning")  # the parts sit off the origin
@pytest.mark.parametrize("suffix", [".obj", ".stl"])
def test_parts_touching_along_a_face_become_one_body(tmp_path, suffix):
    """Two cubes sharing a face: an OBJ keeps each part's vertices; an STL is a triangle soup whose
    merged vertices make the shared square's edges belong to four faces (identical triangulation
    here, so its coincident face pairs are dropped)."""
    a = trimesh.creation.box(extents=(0.05, 0.05, 0.05))
    b = a.copy()
    b.apply_transform(trimesh.transformations.reflection_matrix((0.025, 0, 0), (1, 0, 0)))  # keeps outward winding
    path = tmp_path / f"two_cubes{suffix}"
    trimesh.util.concatenate([a, b]).export(path)
    with pytest.warns(UserWarning, match="repaired mesh"):
        model = objects.load(path, cache_dir=tmp_path)
    assert model.mesh.is_watertight and model.mesh.body_count == 1
    assert model.mesh.volume == pytest.approx(2 * 0.05**3, rel=1e-6)
    np.testing.assert_allclose(model.extent_m, [0.10, 0.05, 0.05], atol=1e-6)


def test_a_single_clean_part_needs_no_warning(tmp_path):
    path = tmp_path / "ball.ply"
    trimesh.creation.icosphere(subdivisions=3, radius=0.04).export(path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        objects.load(path, cache_dir=tmp_path)


@pytest.mark.parametrize("units, extents, scale", [("mm", (120.0, 80.0, 60.0), 0.001),
                                                    ("cm", (12.0, 8.0, 6.0), 0.01)])
def test_a_mesh_in_other_units_is_refused_naming_the_flag_and_the_flag_loads_it(tmp_path, units, extents, scale):
    path = tmp_path / "part.stl"
    trimesh.creation.box(extents=extents).export(path)
    with pytest.raises(ValueError, match=rf"part\.stl: .*hand-held object; the file is likely in \w+: "
                                         rf"pass --units {units} \(scale={scale:g} from Python\), "
                                         rf"which makes it 120 mm"):
        objects.load(path, cache_dir=tmp_path)
    with pytest.raises(ValueError, match=f"pass --units {units}"):
        objects.in_metres(path, "m", cache_dir=tmp_path)  # what the commands call first
    converted = objects.in_metres(path, units, cache_dir=tmp_path)
    model = objects.load(converted)  # the copy in metres loads by name alone
    np.testing.assert_allclose(model.extent_m, [0.12, 0.08, 0.06], atol=1e-9)
    assert model.name == "part"


def test_a_mesh_made_too_small_by_a_wrong_unit_is_refused_naming_metres(tmp_path):
    path = tmp_path / "part.obj"
    trimesh.creation.box(extents=(0.12, 0.08, 0.06)).export(path)
    with pytest.raises(ValueError, match=r"0\.12 mm .*likely in metres: pass --units m "):
        objects.in_metres(path, "mm", cache_dir=tmp_path)
    assert objects.in_metres(path, "m", cache_dir=tmp_path) == str(path)  # metres: the file itself


def test_a_mesh_file_named_relative_to_here_is_passed_on_as_an_absolute_path(tmp_path, monkeypatch):
    """So a session recorded with it names a file that a replay from another directory finds."""
    (tmp_path / "parts").mkdir()
    trimesh.creation.box(extents=(0.12, 0.08, 0.06)).export(tmp_path / "parts" / "part.stl")
    monkeypatch.chdir(tmp_path)
    name = objects.in_metres("parts/part.stl", "m", cache_dir=tmp_path / "cache")
    assert name == str(tmp_path / "parts" / "part.stl")
    monkeypatch.chdir(tmp_path / "parts")
    np.testing.assert_allclose(objects.load(name).extent_m, [0.12, 0.08, 0.06], atol=1e-9)


def test_units_are_checked():
    with pytest.raises(ValueError, match="unknown length unit 'furlong'; choose from m, cm, mm, in"):
        objects.units_scale("furlong")


# --- the commands and the rig configuration ------------------------------------------------------

def test_explore_refuses_a_millimetre_mesh_before_running_and_names_the_flag(tmp_path, capsys):
    from scripts.explore import main

    path = tmp_path / "part.stl"
    trimesh.creation.box(extents=(120.0, 80.0, 60.0)).export(path)
    with pytest.raises(SystemExit) as stop:
        main(["--object", str(path), "--out", str(tmp_path / "run"), "--touches", "1"])
    assert stop.value.code == 2
    assert "pass --units mm" in capsys.readouterr().err
    assert not (tmp_path / "run").exists()
    with pytest.raises(SystemExit) as stop:
        main(["--object", "generated:mug", "--out", str(tmp_path / "run")])
    assert stop.value.code == 2
    assert "expected generated:FAMILY/SEED" in capsys.readouterr().err


def test_a_sweep_takes_generated_names_and_labels_them_for_file_names():
    from explorer.sweep import SweepConfig
    from explorer.sweep.plan import plan_runs

    config = SweepConfig(objects=("generated:mug/0", "box"), strategies=("random",), seeds=(0,))
    assert config.objects == ("generated:mug/0", "box")
    assert [run.name for run in plan_runs(config)] == ["generated-mug-0-random-normals-seed0",
                                                        "box-random-normals-seed0"]
    with pytest.raises(ValueError, match="unknown generated family 'cup'.*families: mug"):
        SweepConfig(objects=("generated:cup/0",), strategies=("random",), seeds=(0,))


def test_the_rig_configuration_gives_the_reference_mesh_unit(tmp_path):
    from explorer.config import MESH_UNITS, config_from_dict
    from explorer.backends import _reference

    path = tmp_path / "mug.stl"
    trimesh.creation.box(extents=(120.0, 80.0, 60.0)).export(path)
    emulated = {"robot": {"backend": "emulated"}, "sensor": {"backend": "emulated"}}
    config = config_from_dict({**emulated, "object": {"reference_mesh": str(path), "units": "mm"}})
    np.testing.assert_allclose(_reference(config).extents, [0.12, 0.08, 0.06], atol=1e-9)
    off_centre = tmp_path / "registered.stl"  # registered to the real object's frame: never moved
    trimesh.creation.box(extents=(120.0, 80.0, 60.0)).apply_translation([0.0, 0.0, 30.0]).export(off_centre)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        reference = _reference(config_from_dict({**emulated, "object": {"reference_mesh": str(off_centre),
                                                                         "units": "mm"}}))
    np.testing.assert_allclose(reference.bounds, [[-0.06, -0.04, 0.0], [0.06, 0.04, 0.06]], atol=1e-9)
    config = config_from_dict({**emulated, "object": {"reference_mesh": str(path)}})
    with pytest.raises(ValueError, match=r"object\.reference_mesh: .*set object\.units = mm "):
        _reference(config)
    with pytest.raises(ValueError, match=r"object\.units: expected one of m, cm, mm, in"):
        config_from_dict({"object": {"units": "feet"}})
    assert set(objects.UNITS) == set(MESH_UNITS)
