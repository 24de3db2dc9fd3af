"""Mesh topology (reconstruction.topology) against closed forms and against manifold3d's genus."""
import manifold3d
import numpy as np
import pytest
import trimesh

import objects
from explorer.evaluation import reconstruction_errors
from reconstruction.gpis import GPIS
from reconstruction.synthetic_contacts import sample_contacts
from reconstruction.topology import surface_topology


def manifold_genus(mesh: trimesh.Trimesh) -> int:
    """Handles summed over the parts, by manifold3d (an independent implementation; needs a closed
    manifold mesh; its ``genus`` is ``1 - chi / 2`` of one part, so the parts are taken apart first)."""
    solid = manifold3d.Manifold(manifold3d.Mesh(vert_properties=np.asarray(mesh.vertices, np.float32),
                                                tri_verts=np.asarray(mesh.faces, np.uint32)))
    assert solid.status() == manifold3d.Error.NoError
    return sum(int(part.genus()) for part in solid.decompose())


def test_closed_forms():
    sphere = trimesh.creation.icosphere(subdivisions=2)
    torus = trimesh.creation.torus(0.05, 0.01)
    two = trimesh.util.concatenate([sphere, sphere.copy().apply_translation([3.0, 0.0, 0.0])])
    assert surface_topology(sphere).as_dict() == dict(components=1, euler_characteristic=2, genus=0,
                                                     boundary_loops=0, non_manifold_edges=0)
    assert (surface_topology(torus).genus, surface_topology(torus).euler_characteristic) == (1, 0)
    assert (surface_topology(two).components, surface_topology(two).euler_characteristic,
            surface_topology(two).genus) == (2, 4, 0)


def test_open_surfaces_count_their_boundary_loops():
    sphere = trimesh.creation.icosphere(subdivisions=3)
    normals_z = sphere.face_normals[:, 2]
    cap = trimesh.Trimesh(sphere.vertices, sphere.faces[normals_z < 0.9])  # a hole at the top: a disc
    band = trimesh.Trimesh(sphere.vertices, sphere.faces[np.abs(normals_z) < 0.9])  # an open tube
    for mesh, loops, chi in ((cap, 1, 1), (band, 2, 0)):
        topology = surface_topology(mesh)
        assert (topology.boundary_loops, topology.euler_characteristic, topology.genus) == (loops, chi, 0)


def test_non_manifold_edges_are_counted():
    fan = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]],
                          [[0, 1, 2], [0, 1, 3], [0, 1, 4]], process=False)
    assert surface_topology(fan).non_manifold_edges == 1


def test_an_empty_mesh_is_refused():
    with pytest.raises(ValueError, match="no faces"):
        surface_topology(trimesh.Trimesh(np.zeros((3, 3)), np.zeros((0, 3), dtype=int)))


@pytest.mark.parametrize("name", ["generated:mug/0", "generated:ring/0", "generated:plate/0", "generated:torus/0"])
def test_genus_agrees_with_manifold3d_on_generated_shapes(name):
    mesh = objects.load(name).mesh
    topology = surface_topology(mesh)
    assert topology.genus == manifold_genus(mesh)
    assert topology.euler_characteristic == mesh.euler_number


def test_genus_agrees_with_manifold3d_on_a_reconstruction_with_holes():
    """A thin plate rebuilt from 100 sampled contacts: the 0-level set has holes through it."""
    truth = objects.load("generated:plate/0").mesh
    points, normals, _, _ = sample_contacts(truth, 100, seed=100)
    lo, hi = truth.bounds
    pad = 0.2 * float(np.max(hi - lo))
    mesh = GPIS(bounds=(lo - pad, hi + pad)).fit(points, normals).mesh(resolution=48)
    assert mesh.is_watertight
    assert surface_topology(mesh).genus == manifold_genus(mesh)


def test_metrics_name_the_extra_handles_and_parts():
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=0.05)
    torus = trimesh.creation.torus(0.04, 0.012)
    two = trimesh.util.concatenate([sphere, sphere.copy().apply_translation([0.2, 0.0, 0.0])])
    none = np.zeros((0, 3))
    same = reconstruction_errors(sphere, sphere, none, none)
    assert (same["extra_handles"], same["extra_components"]) == (0, 0)
    holed = reconstruction_errors(torus, sphere, none, none)
    assert (holed["extra_handles"], holed["topology"]["genus"], holed["truth_topology"]["genus"]) == (1, 1, 0)
    split = reconstruction_errors(two, sphere, none, none)
    assert (split["extra_handles"], split["extra_components"]) == (0, 1)
