"""Generated URDFs: regeneration matches the committed files; published figures; inertias."""
from __future__ import annotations

import math
import xml.etree.ElementTree as ElementTree

import numpy as np
import pytest

from robots import armar3, armar6
from robots.fingertip import FingertipGeometry, fingertip_parts
from robots.generate import MODELS, urdf_path, urdf_text, write_all
from robots.urdf_model import Box, Cylinder, Joint, Link, RobotModel, Shape, Sphere, link_inertia, to_urdf


@pytest.mark.parametrize("name", sorted(MODELS))
def test_committed_urdf_matches_regeneration(name, tmp_path):
    committed = urdf_path(name).read_text()
    assert committed == urdf_text(name), f"run 'python -m robots.generate' to refresh {urdf_path(name)}"
    (written,) = [p for p in write_all(tmp_path) if p.name == f"{name}.urdf"]
    assert written.read_bytes() == urdf_path(name).read_bytes()


def _tree(name):
    return ElementTree.parse(urdf_path(name)).getroot()


def _joints(root, kind):
    return [j for j in root.findall("joint") if j.get("type") == kind]


def test_armar3_has_the_published_limits_masses_and_lengths():
    root = _tree("armar3")
    revolute = {j.get("name"): j for j in _joints(root, "revolute")}
    assert set(revolute) == set(armar3.JOINT_NAMES) | {"spring_x", "spring_y"}
    published_deg = [(-106.94, 80), (-13.85, 94.62), (-108.11, 73.94), (-114.58, 55), (-69.65, 108.25),
                     (-29.18, 29.88), (-30.9, 50.87)]
    for name, (lo, hi) in zip(armar3.JOINT_NAMES, published_deg):
        limit = revolute[name].find("limit")
        assert math.degrees(float(limit.get("lower"))) == pytest.approx(lo, abs=1e-9)
        assert math.degrees(float(limit.get("upper"))) == pytest.approx(hi, abs=1e-9)
        assert float(limit.get("effort")) > 0 and float(limit.get("velocity")) > 0
    masses = {link.get("name"): float(link.find("inertial/mass").get("value")) for link in root.findall("link")}
    arm_links = ["shoulder_1_link", "shoulder_2_link", "upper_arm_link", "elbow_link", "forearm_link",
                 "wrist_1_link", "wrist_2_link"]
    assert [masses[n] for n in arm_links] == [3.65, 2.5, 1.56, 1.16, 2.27, 1.30, 0.2]
    origins = {j.get("name"): np.array(j.find("origin").get("xyz").split(), float) for j in root.findall("joint")}
    assert origins["shoulder_1"][1] == pytest.approx(-0.232)
    assert origins["elbow"] == pytest.approx([0.020, 0.0, -0.310])
    assert np.linalg.norm(origins["forearm"]) == pytest.approx(0.0075)
    assert origins["wrist_1"] == pytest.approx([0.0, 0.0, -0.240])
    assert origins["hand_to_tool"] == pytest.approx([0.0, 0.0, -0.130])


def test_armar6_has_eight_actuated_joints_and_a_longer_reach():
    root3, root6 = _tree("armar3"), _tree("armar6")
    actuated = [j.get("name") for j in _joints(root6, "revolute") if not j.get("name").startswith("spring")]
    assert actuated == list(armar6.JOINT_NAMES) and len(actuated) == 8

    def reach(root):
        names = ("elbow", "wrist_1", "hand_to_tool")
        return sum(np.linalg.norm(np.array(j.find("origin").get("xyz").split(), float))
                   for j in root.findall("joint") if j.get("name") in names)

    assert reach(root6) > reach(root3) + 0.1


@pytest.mark.parametrize("name", sorted(MODELS))
def test_every_link_has_a_physical_inertia(name):
    for link in _tree(name).findall("link"):
        el = link.find("inertial/inertia")
        i = np.array([[float(el.get("ixx")), float(el.get("ixy")), float(el.get("ixz"))],
                      [float(el.get("ixy")), float(el.get("iyy")), float(el.get("iyz"))],
                      [float(el.get("ixz")), float(el.get("iyz")), float(el.get("izz"))]])
        eig = np.linalg.eigvalsh(i)
        assert eig.min() > 0, link.get("name")
        # triangle inequality of principal moments holds for every real body
        assert eig[0] + eig[1] >= eig[2] * (1 - 1e-9), link.get("name")


def test_fingertip_frames_and_dimensions():
    geometry = FingertipGeometry()
    links, joints = fingertip_parts("tool", geometry)
    by_name = {j.name: j for j in joints}
    assert by_name["spring_x"].axis == (1.0, 0.0, 0.0) and by_name["spring_y"].axis == (0.0, 1.0, 0.0)
    for spring in ("spring_x", "spring_y"):
        assert by_name[spring].xyz == (0.0, 0.0, 0.0)
        assert math.radians(50) <= by_name[spring].upper <= math.radians(60)
        assert by_name[spring].lower == -by_name[spring].upper
    # pivot -> pad face: spring gap + 7.7 mm module, all along +z (the pad's outward normal)
    total = by_name["plate_to_body"].xyz[2] + by_name["body_to_pad"].xyz[2]
    assert total == pytest.approx(geometry.spring_gap_m + 0.0077)
    pad = {link.name: link for link in links}["pad"]
    (shape,) = pad.shapes
    assert shape.geometry.size_m == pytest.approx((0.018, 0.018, 0.0037))
    assert shape.xyz[2] + shape.geometry.size_m[2] / 2 == pytest.approx(0.0)  # face at the pad frame
    with pytest.raises(ValueError, match="pad thickness"):
        FingertipGeometry(pad_thickness_m=0.01)


def test_link_inertia_matches_closed_forms():
    m, r, h = 2.0, 0.05, 0.3
    _, cyl = link_inertia(Link("c", m, shapes=(Shape(Cylinder(r, h), rpy=(0.0, math.pi / 2, 0.0)),)))
    # cylinder turned onto the x axis: axial moment about x
    assert cyl[0, 0] == pytest.approx(m * r * r / 2)
    assert cyl[1, 1] == pytest.approx(m * (3 * r * r + h * h) / 12)
    # two equal spheres at +-d along x: parallel-axis theorem
    d, rs = 0.1, 0.02
    com, pair = link_inertia(Link("s", m, shapes=(Shape(Sphere(rs), xyz=(d, 0, 0)), Shape(Sphere(rs), xyz=(-d, 0, 0)))))
    assert com == pytest.approx([0, 0, 0])
    assert pair[1, 1] == pytest.approx(0.4 * m * rs * rs + m * d * d)
    assert pair[0, 0] == pytest.approx(0.4 * m * rs * rs)
    # spheres on the diagonal: product of inertia Ixy = -sum(m x y)
    _, diag = link_inertia(Link("s", m, shapes=(Shape(Sphere(rs), xyz=(d, d, 0)), Shape(Sphere(rs), xyz=(-d, -d, 0)))))
    assert diag[0, 1] == pytest.approx(-m * d * d)
    # a box about its own centre: (b^2 + c^2) / 12 per kilogram
    com, box = link_inertia(Link("b", 3.0, shapes=(Shape(Box((0.1, 0.2, 0.3)), xyz=(0.1, 0.2, 0.0)),)))
    assert com == pytest.approx([0.1, 0.2, 0.0])
    assert np.diag(box) == pytest.approx(3.0 * np.array([0.13, 0.10, 0.05]) / 12)


def test_writer_rejects_bad_models():
    link = Link("a", 1.0)
    with pytest.raises(ValueError, match="unknown link 'b'"):
        to_urdf(RobotModel("r", (link,), (Joint("j", "fixed", "a", "b"),)))
    with pytest.raises(ValueError, match="duplicate link"):
        to_urdf(RobotModel("r", (link, link)))
    with pytest.raises(ValueError, match="lower limit"):
        to_urdf(RobotModel("r", (link, Link("b", 1.0)), (Joint("j", "revolute", "a", "b", lower=1, upper=0),)))
    with pytest.raises(ValueError, match="mass must be positive"):
        to_urdf(RobotModel("r", (Link("z", 0.0),)))
