"""The sphere model of the arm's collision shapes (robots/link_spheres.py): every sphere set covers
its primitive (points sampled in the primitive lie in a sphere), the batched placement agrees with
the numpy forward kinematics, and spheres clear of a box mean PyBullet finds the arm clear of it."""
from __future__ import annotations

import xml.etree.ElementTree as ElementTree

import numpy as np
import pytest

import robots
from robots.link_spheres import ArmSpheres, _primitive_spheres, read_link_spheres


def _points_in(geometry: ElementTree.Element, n: int, rng) -> np.ndarray:
    """(n, 3) points uniformly in a URDF primitive (its own frame), surface points included."""
    if geometry.tag == "sphere":
        r = float(geometry.get("radius"))
        d = rng.normal(size=(n, 3))
        return r * d / np.linalg.norm(d, axis=1, keepdims=True) * rng.uniform(0, 1, (n, 1)) ** (1 / 3)
    if geometry.tag == "cylinder":
        r, length = float(geometry.get("radius")), float(geometry.get("length"))
        phi, rho = rng.uniform(0, 2 * np.pi, n), r * np.sqrt(rng.uniform(0, 1, n))
        rho[: n // 4] = r  # the rim, where covering is tightest
        return np.column_stack([rho * np.cos(phi), rho * np.sin(phi), rng.uniform(-length / 2, length / 2, n)])
    size = np.array([float(v) for v in geometry.get("size").split()])
    points = rng.uniform(-size / 2, size / 2, (n, 3))
    points[: n // 4] = np.sign(points[: n // 4]) * size / 2  # the corners
    return points


@pytest.mark.parametrize("xml", ['<box size="0.07 0.035 0.08"/>', '<box size="0.3 0.2 1.0"/>',
                                 '<cylinder radius="0.009" length="0.045"/>',
                                 '<cylinder radius="0.05" length="0.02"/>', '<sphere radius="0.06"/>'])
def test_the_spheres_cover_every_point_of_a_primitive(xml):
    geometry = ElementTree.fromstring(xml)
    centres, radii = _primitive_spheres(geometry, "test")
    points = _points_in(geometry, 4000, np.random.default_rng(0))
    inside = np.linalg.norm(points[:, None, :] - centres[None], axis=2) <= radii[None] + 1e-12
    assert inside.any(axis=1).all()
    assert len(radii) <= 30  # a few spheres, not a voxel model


def test_an_unsupported_geometry_is_named():
    with pytest.raises(ValueError, match="mesh.*box, cylinder, sphere"):
        _primitive_spheres(ElementTree.fromstring('<mesh filename="hand.stl"/>'), "URDF x, link 'hand'")


@pytest.mark.parametrize("robot", ["armar3", "armar6"])
def test_arm_spheres_are_placed_by_the_forward_kinematics(robot):
    from robots.kinematics import ArmKinematics

    kin = ArmKinematics(robots.load(robot))
    links = list(kin.link_names[1:kin.link_names.index(kin.spec.tool_link)])
    spheres = ArmSpheres(kin, links)
    rng = np.random.default_rng(1)
    q = rng.uniform(np.maximum(kin.lower_rad, -2.0), np.minimum(kin.upper_rad, 2.0), (3, kin.dof))
    placed = spheres.centres_m(q)
    parts = read_link_spheres(kin.spec.urdf_path, links)
    for b in range(len(q)):
        expected = []
        for part in parts:
            position, rotation = kin.pose_of_one(q[b], link=part.link)  # the numpy chain, not torch
            expected.append(part.centres_m @ rotation.T + position)
        np.testing.assert_allclose(placed[b], np.vstack(expected), atol=1e-9)
    assert len(spheres.radii_m) == sum(len(p.radii_m) for p in parts) == placed.shape[1]


def test_spheres_clear_of_a_box_mean_pybullet_finds_the_arm_clear():
    """Conservative against PyBullet's own collision shapes: wherever the sphere model keeps every
    sphere outside a box, the arm's links (up to the hand) have positive distance to it."""
    import pybullet

    from explorer.free_path import box_signed_distance_m
    from robots.kinematics import ArmKinematics
    from robots.sim_arm import SimArm
    from robots.sim_world import SimWorld

    spec = robots.load("armar6")
    kin = ArmKinematics(spec)
    links = list(kin.link_names[1:kin.link_names.index(spec.tool_link)])
    spheres = ArmSpheres(kin, links)
    centre, half = np.asarray(spec.workspace_center_m, float), np.array([0.06, 0.05, 0.12])
    rng = np.random.default_rng(2)
    with SimWorld() as world:
        arm = SimArm(world, spec)
        client = world.client
        box = pybullet.createMultiBody(0, pybullet.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half.tolist(),
                                                                       physicsClientId=client),
                                       basePosition=centre.tolist(), physicsClientId=client)
        link_index = {name: i for i, name in arm._link_name.items()}
        checked = 0
        for _ in range(200):
            q = rng.uniform(np.maximum(kin.lower_rad, -2.5), np.minimum(kin.upper_rad, 2.5))
            gap = box_signed_distance_m(spheres.centres_m(q[None])[0], centre, half) - spheres.radii_m
            if gap.min() <= 0.0:
                continue
            arm.reset_joint_positions(q)
            for name in links:
                near = pybullet.getClosestPoints(arm.body, box, 0.0, linkIndexA=link_index[name],
                                                 physicsClientId=client)
                assert not near, f"{name} touches the box at {np.round(np.degrees(q), 1)} deg"
            checked += 1
        assert checked > 50
