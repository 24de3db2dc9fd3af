"""Exact distances to the arm's collision primitives (robots/link_shapes.py), checked against two
independent implementations: trimesh's signed distance to the same primitive as a mesh, and
PyBullet's closest points between the arm's own collision shapes and a small ball."""
from __future__ import annotations

import numpy as np
import pytest

import robots
from robots.link_shapes import ArmShapes, primitive_signed_distance_m, read_link_primitives


@pytest.mark.parametrize("kind, half", [("box", np.array([0.03, 0.015, 0.035])),
                                        ("cylinder", np.array([0.035, 0.03])),
                                        ("sphere", np.array([0.02]))])
def test_primitive_distance_matches_trimesh_on_the_same_shape(kind, half):
    import trimesh

    if kind == "box":
        mesh = trimesh.creation.box(extents=2 * half)
    elif kind == "cylinder":
        mesh = trimesh.creation.cylinder(radius=half[0], height=2 * half[1], sections=512)
    else:
        mesh = trimesh.creation.icosphere(subdivisions=6, radius=half[0])
    rng = np.random.default_rng(0)
    points = rng.uniform(-1.0, 1.0, (400, 3)) * np.resize(half, 3) * 2.0  # half inside, half outside on each axis
    expected = -trimesh.proximity.signed_distance(mesh, points)  # trimesh: positive inside
    got = primitive_signed_distance_m(kind, half, points)
    assert (got < 0).sum() > 10 and (got > 0).sum() > 100, "premise: points on both sides"
    np.testing.assert_allclose(got, expected, atol=5e-5)  # the meshes are faceted by up to 0.03 mm


@pytest.mark.parametrize("robot", ["armar3", "armar6"])
def test_arm_shape_distances_match_pybullet_closest_points(robot):
    """Random configurations, balls of 2 mm radius placed near the forearm and wrist: the model's
    distance minus the radius is PyBullet's distance between the links and the ball. To 1.2 mm:
    PyBullet's distances to the links' cylinders come out 0.8-1.0 mm short of the exact ones (its
    collision margin); to their boxes they agree to 0.01 mm."""
    import pybullet

    from robots.kinematics import ArmKinematics
    from robots.sim_arm import SimArm
    from robots.sim_world import SimWorld

    spec = robots.load(robot)
    kin = ArmKinematics(spec)
    names = list(kin.link_names)
    links = names[names.index("forearm_link"):names.index(spec.tool_link)]
    shapes = ArmShapes(kin, links)
    radius = 0.002
    rng = np.random.default_rng(3)
    compared = 0
    with SimWorld() as world:
        arm = SimArm(world, spec)
        client = world.client
        ball = pybullet.createMultiBody(0, pybullet.createCollisionShape(pybullet.GEOM_SPHERE, radius=radius,
                                                                        physicsClientId=client),
                                        physicsClientId=client)
        link_index = {name: i for i, name in arm._link_name.items()}
        for _ in range(6):
            q = rng.uniform(np.maximum(kin.lower_rad, -2.0), np.minimum(kin.upper_rad, 2.0))
            arm.reset_joint_positions(q)
            wrist = kin.pose_of_one(q, link=links[-1])[0]
            for point in wrist + rng.normal(0.0, 0.05, (15, 3)):
                pybullet.resetBasePositionAndOrientation(ball, point.tolist(), [0, 0, 0, 1], physicsClientId=client)
                found = []
                for name in links:
                    found += [c[8] for c in pybullet.getClosestPoints(arm.body, ball, 0.2, linkIndexA=link_index[name],
                                                                      physicsClientId=client)]
                if not found or min(found) <= 0.0:
                    continue  # PyBullet's penetration depths are not distances
                got = shapes.signed_distance_m(q[None], point[None])[0] - radius
                assert got == pytest.approx(min(found), abs=1.2e-3)
                compared += 1
    assert compared > 40


def test_a_mesh_collision_shape_is_refused_with_the_fix(tmp_path):
    urdf = tmp_path / "hand.urdf"
    urdf.write_text('<robot name="r"><link name="hand"><collision><geometry><mesh filename="hand.stl"/>'
                    '</geometry></collision></link></robot>')
    with pytest.raises(ValueError, match="give the link primitive collision shapes"):
        read_link_primitives(urdf, ["hand"])
    with pytest.raises(ValueError, match="no link 'palm'"):
        read_link_primitives(urdf, ["palm"])
