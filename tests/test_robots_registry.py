"""Robot specs: built-in robots, user registration, JSON files and URDF checks."""
from __future__ import annotations

import dataclasses
import uuid

import numpy as np
import pytest

import robots
from robots import armar3
from robots.fingertip import fingertip_parts
from robots.registry import RobotRegistry, armar3_spec
from robots.spec import RobotSpec
from robots.urdf_check import check_spec_against_urdf
from robots.urdf_model import RobotModel, to_urdf


@pytest.mark.parametrize("name, dof", [("armar3", 7), ("armar6", 8)])
def test_builtin_robots_load(name, dof):
    spec = robots.load(name)
    assert spec.name == name and spec.dof == dof and spec.urdf_path.is_file()
    assert spec.spring_joint_names == ("spring_x", "spring_y")
    assert (spec.pivot_link, spec.sensor_body_link, spec.pad_link) == ("sensor_pivot", "sensor_body", "pad")
    assert spec.home_q.shape == (dof,)
    assert dataclasses.is_dataclass(spec)
    with pytest.raises(dataclasses.FrozenInstanceError):
        spec.name = "other"
    check_spec_against_urdf(spec)  # home within limits, all parts present
    assert {"armar3", "armar6"} <= set(robots.names())


def test_unknown_name_lists_the_valid_names():
    with pytest.raises(ValueError, match=r"unknown robot 'armar9'.*armar3, armar6"):
        robots.load("armar9")


def _arm_urdf(tmp_path, with_fingertip=True, name="user_arm"):
    links, joints = armar3.arm_links(), armar3.arm_joints()
    if with_fingertip:
        tip_links, tip_joints = fingertip_parts("tool")
        links, joints = links + tip_links, joints + tip_joints
    path = tmp_path / f"{name}.urdf"
    path.write_text(to_urdf(RobotModel(name, links, joints)))
    return path


def _user_spec(urdf, name="user_arm", **changes):
    base = dict(name=name, urdf_path=urdf, joint_names=armar3.JOINT_NAMES, home_q_rad=armar3_spec().home_q_rad)
    base.update(changes)
    return RobotSpec(**base)


def test_user_robot_registers_and_loads(tmp_path):
    registry = RobotRegistry()
    spec = registry.register(_user_spec(_arm_urdf(tmp_path)))
    assert registry.names() == ["user_arm"] and registry.load("user_arm") is spec
    with pytest.raises(ValueError, match="already registered"):
        registry.register(spec)
    registry.register(dataclasses.replace(spec, spring_stiffness_nm_per_rad=0.05), replace=True)
    assert registry.load("user_arm").spring_stiffness_nm_per_rad == 0.05
    # the module-level registry takes user specs too
    unique = f"user_arm_{uuid.uuid4().hex[:8]}"
    robots.register(dataclasses.replace(spec, name=unique))
    assert robots.load(unique).name == unique and unique in robots.names()


def test_urdf_without_fingertip_names_what_is_missing(tmp_path):
    spec = _user_spec(_arm_urdf(tmp_path, with_fingertip=False))
    with pytest.raises(ValueError, match=r"spring_x.*spring_y.*pivot_link='sensor_pivot'.*pad_link='pad'") as err:
        RobotRegistry().register(spec)
    assert str(spec.urdf_path) in str(err.value)


def test_misplaced_fingertip_joints_are_reported(tmp_path):
    urdf = _arm_urdf(tmp_path)
    # a spec that calls an arm joint a spring and vice versa
    wrong = _user_spec(urdf, joint_names=armar3.JOINT_NAMES[:-1] + ("spring_x",),
                       spring_joint_names=("wrist_2", "spring_y"))
    with pytest.raises(ValueError, match="beyond the pivot"):
        check_spec_against_urdf(wrong)
    missing_file = _user_spec(tmp_path / "nowhere.urdf")
    with pytest.raises(FileNotFoundError, match="nowhere.urdf"):
        check_spec_against_urdf(missing_file)
    outside = _user_spec(urdf, home_q_rad=(3.0,) + armar3_spec().home_q_rad[1:])
    with pytest.raises(ValueError, match="home position 3.0000 rad of joint 'shoulder_1' is outside"):
        check_spec_against_urdf(outside)


def test_spec_json_round_trip_and_load_from_path(tmp_path):
    urdf = _arm_urdf(tmp_path)
    spec = _user_spec(urdf, base_position_m=(0.1, 0.2, 0.0), spring_damping_nms_per_rad=1e-4)
    path = tmp_path / "arm.json"
    spec.to_json(path)
    assert '"urdf_path": "user_arm.urdf"' in path.read_text()  # relative to the JSON file
    loaded = robots.load(path)
    assert loaded == spec
    path.write_text(path.read_text().replace('"name"', '"nmae"'))
    with pytest.raises(ValueError, match=r"unknown fields \['nmae'\]"):
        robots.load(path)


def test_spec_rejects_bad_values(tmp_path):
    urdf = _arm_urdf(tmp_path)
    with pytest.raises(ValueError, match="home_q_rad must have 7 values"):
        _user_spec(urdf, home_q_rad=(0.0,) * 6)
    with pytest.raises(ValueError, match="spring_stiffness_nm_per_rad must be positive"):
        _user_spec(urdf, spring_stiffness_nm_per_rad=0.0)
    with pytest.raises(ValueError, match="unit quaternion"):
        _user_spec(urdf, base_quat_wxyz=(2.0, 0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="must not be actuated"):
        _user_spec(urdf, spring_joint_names=("elbow", "spring_y"))
    with pytest.raises(ValueError, match="duplicate joint names"):
        _user_spec(urdf, joint_names=("elbow",) * 7)
    spec = _user_spec(urdf, base_quat_wxyz=(0.0, 0.0, 0.0, 1.0))
    assert np.allclose(spec.base_quat_wxyz, (0, 0, 0, 1)) and isinstance(spec.home_q_rad, tuple)
