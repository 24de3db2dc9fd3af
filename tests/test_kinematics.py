"""FK and Jacobians built from the URDF agree with PyBullet and with finite differences."""
from __future__ import annotations

import dataclasses

import numpy as np
import pybullet
import pytest

from robots.fingertip import FingertipGeometry

import robots
from robots.kinematics import ArmKinematics
from robots.pybullet_types import JointInfo, LinkState
from common.rotations import matrix_to_quat, quat_to_matrix, rotation_angle_between

# an arbitrary base pose, so that the base transform is exercised too
BASE_POSITION = (0.3, -0.1, 0.05)
BASE_QUAT_WXYZ = tuple(np.array([np.cos(0.35), 0.0, 0.0, np.sin(0.35)]))


@pytest.fixture(scope="module", params=["armar3", "armar6"])
def moved_spec(request):
    return dataclasses.replace(robots.load(request.param), base_position_m=BASE_POSITION, base_quat_wxyz=BASE_QUAT_WXYZ)


@pytest.fixture(scope="module")
def kinematics(moved_spec):
    return ArmKinematics(moved_spec)


@pytest.fixture(scope="module")
def bullet_arm(moved_spec):
    client = pybullet.connect(pybullet.DIRECT)
    xyzw = np.roll(moved_spec.base_quat_wxyz, -1).tolist()
    body = pybullet.loadURDF(str(moved_spec.urdf_path), BASE_POSITION, xyzw, useFixedBase=True,
                             physicsClientId=client)
    infos = [JointInfo.from_pybullet(pybullet.getJointInfo(body, i, physicsClientId=client))
             for i in range(pybullet.getNumJoints(body, physicsClientId=client))]
    yield client, body, {i.name: i.index for i in infos}, {i.child_link_name: i.index for i in infos}
    pybullet.disconnect(client)


def _random_configs(kin, n, seed):
    rng = np.random.default_rng(seed)
    q = rng.uniform(kin.lower_rad, kin.upper_rad, (n, kin.dof))
    springs = rng.uniform(-0.9, 0.9, (n, 2))
    return q, springs


def test_fk_matches_pybullet_link_poses(kinematics, bullet_arm):
    client, body, joint_index, link_index = bullet_arm
    spec = kinematics.spec
    q, springs = _random_configs(kinematics, 12, seed=1)
    for qi, si in zip(q, springs):
        for name, value in zip(spec.joint_names + spec.spring_joint_names, np.concatenate([qi, si])):
            pybullet.resetJointState(body, joint_index[name], value, physicsClientId=client)
        for link in kinematics.link_names[1:]:
            raw = pybullet.getLinkState(body, link_index[link], computeLinkVelocity=1, computeForwardKinematics=1,
                                        physicsClientId=client)
            truth = LinkState.from_pybullet(raw)
            fk = kinematics.forward_kinematics(qi, link, spring_rad=si)
            assert np.abs(fk.position_m - truth.position_m).max() < 1e-6, link
            assert rotation_angle_between(fk.rotation, truth.rotation) < 1e-6, link


def test_fk_is_batched_and_shapes_follow_the_input(kinematics):
    q, springs = _random_configs(kinematics, 6, seed=2)
    batch = kinematics.forward_kinematics(q.reshape(2, 3, -1), spring_rad=springs.reshape(2, 3, 2))
    assert batch.position_m.shape == (2, 3, 3) and batch.rotation.shape == (2, 3, 3, 3)
    for i in range(6):
        single = kinematics.forward_kinematics(q[i], spring_rad=springs[i])
        assert np.allclose(single.position_m, batch.position_m.reshape(6, 3)[i], atol=1e-12)
    assert batch.position_m.dtype == np.float64


def test_pad_frame_sits_on_the_sensor_body_axis(kinematics):
    q, springs = _random_configs(kinematics, 5, seed=3)
    body = kinematics.forward_kinematics(q, kinematics.spec.sensor_body_link, springs)
    pad = kinematics.forward_kinematics(q, kinematics.spec.pad_link, springs)
    offset = np.einsum("nji,nj->ni", body.rotation, pad.position_m - body.position_m)
    assert np.allclose(offset[:, :2], 0.0, atol=1e-9) and np.all(offset[:, 2] > 0.004)  # pad face along +z
    assert np.allclose(body.rotation, pad.rotation, atol=1e-9)


def test_jacobian_matches_finite_differences(kinematics):
    q, springs = _random_configs(kinematics, 4, seed=4)
    step = 1e-6
    for link in (kinematics.spec.pad_link, kinematics.spec.pivot_link, "elbow_link"):
        jac = kinematics.jacobian(q, link, spring_rad=springs)
        assert jac.shape == (4, 6, kinematics.dof)
        for j in range(kinematics.dof):
            dq = np.zeros(kinematics.dof)
            dq[j] = step
            plus = kinematics.forward_kinematics(q + dq, link, springs)
            minus = kinematics.forward_kinematics(q - dq, link, springs)
            linear = (plus.position_m - minus.position_m) / (2 * step)
            # angular velocity from dR R^T (skew part)
            d_rot = (plus.rotation - minus.rotation) / (2 * step)
            omega_hat = d_rot @ np.swapaxes(plus.rotation + minus.rotation, 1, 2) / 2
            angular = np.stack([omega_hat[:, 2, 1], omega_hat[:, 0, 2], omega_hat[:, 1, 0]], axis=1)
            assert np.allclose(jac[:, :3, j], linear, atol=1e-7), (link, j)
            assert np.allclose(jac[:, 3:, j], angular, atol=1e-7), (link, j)


def test_spring_columns_of_the_jacobian_match_finite_differences(kinematics):
    q, springs = _random_configs(kinematics, 3, seed=6)
    jac = kinematics.jacobian(q, spring_rad=springs, with_springs=True)
    assert jac.shape == (3, 6, kinematics.dof + 2)
    assert np.allclose(jac[:, :, :kinematics.dof], kinematics.jacobian(q, spring_rad=springs))
    step = 1e-6
    for j in range(2):
        ds = np.zeros(2)
        ds[j] = step
        plus = kinematics.forward_kinematics(q, spring_rad=springs + ds)
        minus = kinematics.forward_kinematics(q, spring_rad=springs - ds)
        linear = (plus.position_m - minus.position_m) / (2 * step)
        assert np.allclose(jac[:, :3, kinematics.dof + j], linear, atol=1e-7)
        # the pad turns about the spring axis through the pivot: v = axis x (pad - pivot)
        frame = kinematics.forward_kinematics(q, ("sensor_pivot", "spring_gimbal")[j], springs)
        axis = frame.rotation[:, :, j]
        pad = kinematics.forward_kinematics(q, spring_rad=springs).position_m
        assert np.allclose(np.cross(axis, pad - frame.position_m), linear, atol=1e-7)
    # arm links before the pivot do not depend on the springs
    assert np.allclose(kinematics.jacobian(q, "elbow_link", springs, with_springs=True)[:, :, -2:], 0.0)


def test_pad_position_from_measured_orientation(kinematics):
    """Pivot from the encoders + IMU orientation reproduces the true pad with deflected springs."""
    spec = kinematics.spec
    q, springs = _random_configs(kinematics, 8, seed=5)
    body = kinematics.forward_kinematics(q, spec.sensor_body_link, springs)
    truth = kinematics.forward_kinematics(q, spec.pad_link, springs).position_m
    estimate = kinematics.pad_position_from_orientation(q, matrix_to_quat(body.rotation))
    assert np.abs(estimate - truth).max() < 1e-9
    # ignoring the spring (orientation of the undeflected pad) is off by millimetres
    undeflected = kinematics.forward_kinematics(q, spec.sensor_body_link)
    naive = kinematics.pad_position_from_orientation(q, matrix_to_quat(undeflected.rotation))
    assert np.linalg.norm(naive - truth, axis=1).min() > 1e-3
    offset = kinematics.pivot_to_pad_in_body
    assert offset[:2] == pytest.approx([0.0, 0.0], abs=1e-12)
    assert offset[2] == pytest.approx(FingertipGeometry().pivot_to_pad_m, abs=1e-9)
    assert np.allclose(quat_to_matrix(matrix_to_quat(body.rotation)), body.rotation)


def test_bad_inputs_are_rejected(kinematics):
    with pytest.raises(ValueError, match=r"q must have shape \(\.\.\., \d\)"):
        kinematics.forward_kinematics(np.zeros(3))
    with pytest.raises(ValueError, match="non-finite"):
        kinematics.forward_kinematics(np.full(kinematics.dof, np.nan))
    with pytest.raises(ValueError, match="link 'hand' is not on the chain"):
        kinematics.forward_kinematics(kinematics.spec.home_q, "hand")
    with pytest.raises(ValueError, match="unit quaternions"):
        kinematics.pad_position_from_orientation(kinematics.spec.home_q, [2.0, 0, 0, 0])


def test_batched_fk_is_pytorch_kinematics_to_rounding(kinematics, moved_spec):
    """The chain composed here against pytorch_kinematics' own forward kinematics of the same URDF,
    every link, springs deflected, base moved. The same products in the same order: on the
    project's machine equal to the last bit; asserted to 1e-13 (metres and rotation entries), as
    another CPU's matrix kernels may round the two batch layouts differently."""
    import pytorch_kinematics as pk
    import torch

    chain = pk.build_serial_chain_from_urdf(moved_spec.urdf_path.read_text(), moved_spec.pad_link).to(dtype=torch.float64)
    inputs = list(moved_spec.joint_names) + list(moved_spec.spring_joint_names)
    order = [inputs.index(name) for name in chain.get_joint_parameter_names()]
    frames = [chain.frame_to_idx[name] for name in kinematics.link_names]
    base = torch.eye(4, dtype=torch.float64)
    base[:3, :3] = torch.as_tensor(quat_to_matrix(moved_spec.base_quat_wxyz), dtype=torch.float64)
    base[:3, 3] = torch.as_tensor(moved_spec.base_position_m, dtype=torch.float64)
    for n in (1, 7, 300):
        q, springs = _random_configs(kinematics, n, seed=n)
        q_t, springs_t = torch.as_tensor(q), torch.as_tensor(springs)
        expected = base @ chain.forward_kinematics_tensor(torch.cat([q_t, springs_t], 1)[:, order])[frames]
        got = kinematics.link_transforms(q_t, springs_t)
        assert got.shape == (len(kinematics.link_names), n, 4, 4)
        torch.testing.assert_close(got, expected, atol=1e-13, rtol=0)


def test_numpy_pose_of_one_is_the_batched_fk_at_random_angles(kinematics):
    """The per-tick numpy FK against the batched torch FK, every link, springs deflected (1e-9 m, 1e-9)."""
    q, springs = _random_configs(kinematics, 40, seed=7)
    for link in kinematics.link_names:
        batched = kinematics.forward_kinematics(q, link, springs)
        for i in range(len(q)):
            position, rotation = kinematics.pose_of_one(q[i], link, springs[i])
            np.testing.assert_allclose(position, batched.position_m[i], atol=1e-9, rtol=0)
            np.testing.assert_allclose(rotation, batched.rotation[i], atol=1e-9, rtol=0)
    position, _ = kinematics.pose_of_one(q[0])  # default: the pad, springs at 0
    np.testing.assert_allclose(position, kinematics.forward_kinematics(q[0]).position_m, atol=1e-9, rtol=0)
    with pytest.raises(ValueError, match="finite joint angles"):
        kinematics.pose_of_one(q[:3])
