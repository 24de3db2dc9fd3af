"""Forward kinematics and Jacobians of the arm + fingertip, from the robot's own URDF.

The serial chain from the URDF root to the pad link is read with pytorch_kinematics and composed
here (:class:`_SerialChain`), in float64.
Joint vectors ``q`` hold the actuated joints in ``RobotSpec.joint_names`` order (radians); the
two spring angles are separate (``spring_rad``, default 0: the commanded, undeflected pose).
All poses are in the world frame (the spec's base pose applied), metres.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from common.rotations import matrix_to_quat, quat_to_matrix
from robots.spec import RobotSpec
from robots.urdf_check import check_spec_against_urdf

DTYPE = torch.float64


@dataclass(frozen=True)
class LinkPoses:
    """Poses of one link for a batch of configurations.

    Attributes
    ----------
    position_m : (..., 3) float, world frame, metres
    rotation : (..., 3, 3) float, link frame -> world
    """

    position_m: np.ndarray
    rotation: np.ndarray

    @property
    def quat_wxyz(self) -> np.ndarray:
        """(..., 4) orientation quaternions (w, x, y, z)."""
        return matrix_to_quat(self.rotation)

    @property
    def z_axis(self) -> np.ndarray:
        """(..., 3) the link's +z axis in world (for the pad: the outward face normal)."""
        return self.rotation[..., :, 2]


def _load_chain(urdf_path: Path, end_link: str):
    try:
        import pytorch_kinematics as pk
    except ImportError as err:  # a hard dependency, but say what is missing
        raise ImportError("robots.kinematics needs pytorch_kinematics: pip install pytorch-kinematics") from err
    text = Path(urdf_path).read_text()
    return pk.build_serial_chain_from_urdf(text, end_link).to(dtype=DTYPE)


class ArmKinematics:
    """FK and Jacobians of every link on the chain from the URDF root to the pad.

    Parameters
    ----------
    spec : RobotSpec
        The robot; its URDF is checked against the spec first (ValueError if it does not fit).
    """

    def __init__(self, spec: RobotSpec):
        tree = check_spec_against_urdf(spec)
        self.spec = spec
        inputs = list(spec.joint_names) + list(spec.spring_joint_names)
        path = tree.joints_to(spec.pad_link)
        self.link_names: tuple[str, ...] = (tree.root_link,) + tuple(j.child for j in path)
        self._link_index = {name: i for i, name in enumerate(self.link_names)}
        movable = {j.name: j for j in path if j.name in inputs}
        # position along the chain of each input joint's child link, and its axis
        self._input_link_pos = torch.tensor(
            [self.link_names.index(movable[name].child) for name in inputs], dtype=torch.long
        )
        self._input_axis = torch.tensor([movable[name].axis for name in inputs], dtype=DTYPE)
        self._input_axis = self._input_axis / torch.linalg.norm(self._input_axis, dim=1, keepdim=True)
        lower = [tree.joint(n).lower_rad for n in spec.joint_names]
        upper = [tree.joint(n).upper_rad for n in spec.joint_names]
        self.lower_rad = np.array(lower)
        self.upper_rad = np.array(upper)
        base = np.eye(4)
        base[:3, :3] = quat_to_matrix(spec.base_quat_wxyz)
        base[:3, 3] = spec.base_position_m
        self._serial = _SerialChain(_load_chain(spec.urdf_path, spec.pad_link), self.link_names, inputs, base)
        self._pivot_to_pad_in_body = self._pivot_to_pad_offset()

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self.spec.joint_names

    @property
    def dof(self) -> int:
        return self.spec.dof

    # ---- torch level (batched, float64) -------------------------------------------------

    def _inputs(self, q: torch.Tensor, spring_rad: torch.Tensor | None) -> torch.Tensor:
        if spring_rad is None:
            spring_rad = torch.zeros(q.shape[0], 2, dtype=DTYPE)
        return torch.cat([q, spring_rad], dim=1)

    def link_transforms(self, q: torch.Tensor, spring_rad: torch.Tensor | None = None) -> torch.Tensor:
        """World transforms of every chain link, (n_links, B, 4, 4), in ``link_names`` order.

        ``q`` is (B, dof) and ``spring_rad`` (B, 2) or None (springs at 0).
        """
        return self._serial.transforms(self._inputs(q, spring_rad))

    def jacobian_tensor(self, transforms: torch.Tensor, link: str, with_springs: bool = False) -> torch.Tensor:
        """Geometric Jacobian (B, 6, dof [+2]) of ``link``'s origin, world frame, rows (v, omega).

        ``transforms`` comes from :meth:`link_transforms`. Columns follow ``joint_names`` (then the
        spring joints when ``with_springs``).
        """
        index = self._link(link)
        n_inputs = self.dof + (2 if with_springs else 0)
        joint_links = self._input_link_pos[:n_inputs]
        joint_frames = transforms[joint_links]  # (J, B, 4, 4)
        axes = torch.einsum("jbik,jk->jbi", joint_frames[:, :, :3, :3], self._input_axis[:n_inputs])
        lever = transforms[index, :, :3, 3].unsqueeze(0) - joint_frames[:, :, :3, 3]
        linear = torch.cross(axes, lever, dim=-1)
        moves_link = (joint_links <= index).to(DTYPE).reshape(-1, 1, 1)
        jac = torch.cat([linear, axes], dim=-1) * moves_link  # (J, B, 6)
        return jac.permute(1, 2, 0)

    def _link(self, link: str) -> int:
        if link not in self._link_index:
            raise ValueError(f"link {link!r} is not on the chain to the pad; links: {list(self.link_names)}")
        return self._link_index[link]

    def link_index(self, link: str) -> int:
        """Position of ``link`` in :attr:`link_names` (rows of :meth:`link_transforms`)."""
        return self._link(link)

    # ---- numpy level ----------------------------------------------------------------------

    def _as_batch(self, q, spring_rad) -> tuple[torch.Tensor, torch.Tensor | None, tuple[int, ...]]:
        q = np.asarray(q, dtype=float)
        if q.ndim == 0 or q.shape[-1] != self.dof:
            raise ValueError(f"q must have shape (..., {self.dof}) for joints {self.joint_names}, got {q.shape}")
        if not np.all(np.isfinite(q)):
            raise ValueError("q contains non-finite values")
        batch = q.shape[:-1]
        q_t = torch.as_tensor(q.reshape(-1, self.dof), dtype=DTYPE)
        spring_t = None
        if spring_rad is not None:
            spring = np.broadcast_to(np.asarray(spring_rad, dtype=float), batch + (2,))
            if not np.all(np.isfinite(spring)):
                raise ValueError("spring_rad contains non-finite values")
            spring_t = torch.as_tensor(spring.reshape(-1, 2).copy(), dtype=DTYPE)
        return q_t, spring_t, batch

    def pose_of_one(self, q, link: str | None = None, spring_rad=None) -> tuple[np.ndarray, np.ndarray]:
        """(position (3,), rotation (3, 3)) of ``link`` (default: the pad face centre) for one
        configuration ``q`` ((dof,) radians; ``spring_rad`` (2,) or None), world frame.

        The same transforms as :meth:`forward_kinematics` in plain numpy, without its batch and torch
        overhead (tens of microseconds rather than milliseconds): for checks inside a control loop.
        Agrees with it to rounding (``tests/test_kinematics.py``), not necessarily to the last bit.
        """
        q = np.asarray(q, dtype=float)
        if q.shape != (self.dof,) or not np.all(np.isfinite(q)):
            raise ValueError(f"q must be {self.dof} finite joint angles for joints {self.joint_names}, got {q!r}")
        spring = (0.0, 0.0) if spring_rad is None else tuple(float(v) for v in spring_rad)
        transform = self._serial.transform(q.tolist() + list(spring), self._link(link or self.spec.pad_link))
        return transform[:3, 3].copy(), transform[:3, :3].copy()

    def forward_kinematics(self, q, link: str | None = None, spring_rad=None) -> LinkPoses:
        """Pose of ``link`` (default: the pad face centre) for joint positions ``q``.

        Parameters
        ----------
        q : (..., dof) float, radians
        link : str, a name from :attr:`link_names`
        spring_rad : (..., 2) float or None, spring joint angles (0 when None)
        """
        index = self._link(link or self.spec.pad_link)
        q_t, spring_t, batch = self._as_batch(q, spring_rad)
        with torch.no_grad():
            transform = self.link_transforms(q_t, spring_t)[index].numpy()
        return LinkPoses(transform[:, :3, 3].reshape(batch + (3,)), transform[:, :3, :3].reshape(batch + (3, 3)))

    def jacobian(self, q, link: str | None = None, spring_rad=None, with_springs: bool = False) -> np.ndarray:
        """Geometric Jacobian (..., 6, dof [+2]) of ``link``'s origin w.r.t. the actuated joints.

        Rows 0-2: linear velocity (m/s per rad/s), rows 3-5: angular velocity, world frame.
        With ``with_springs`` two more columns follow for the spring joints.
        """
        index_name = link or self.spec.pad_link
        self._link(index_name)
        q_t, spring_t, batch = self._as_batch(q, spring_rad)
        with torch.no_grad():
            jac = self.jacobian_tensor(self.link_transforms(q_t, spring_t), index_name, with_springs).numpy()
        return jac.reshape(batch + (6, self.dof + (2 if with_springs else 0)))

    @property
    def pivot_to_pad_in_body(self) -> np.ndarray:
        """(3,) pivot -> pad face centre offset in the sensor body frame, metres (a constant)."""
        return self._pivot_to_pad_in_body.copy()

    def _pivot_to_pad_offset(self) -> np.ndarray:
        q = self.spec.home_q[None]
        with torch.no_grad():
            t = self.link_transforms(torch.as_tensor(q, dtype=DTYPE))[:, 0].numpy()
        pivot = t[self._link(self.spec.pivot_link)]
        body = t[self._link(self.spec.sensor_body_link)]
        pad = t[self._link(self.spec.pad_link)]
        return body[:3, :3].T @ (pad[:3, 3] - pivot[:3, 3])

    def pad_position_from_orientation(self, q, body_quat_wxyz) -> np.ndarray:
        """Pad face centre in world from the arm encoders and the measured sensor-body orientation.

        The spring is not measured; the IMU gives the body orientation. The pad sits at the
        pivot position (FK of ``q``) plus the measured rotation applied to the body-frame
        pivot -> pad offset.

        Parameters
        ----------
        q : (..., dof) float, radians
        body_quat_wxyz : (..., 4) float, sensor body orientation in world (w, x, y, z)

        Returns
        -------
        (..., 3) float, world frame, metres
        """
        quat = np.asarray(body_quat_wxyz, dtype=float)
        if quat.shape[-1:] != (4,) or not np.all(np.isfinite(quat)):
            raise ValueError(f"body_quat_wxyz must have shape (..., 4) and be finite, got {quat.shape}")
        norms = np.linalg.norm(quat, axis=-1)
        if np.any(np.abs(norms - 1.0) > 0.1):
            raise ValueError("body_quat_wxyz must hold unit quaternions (w, x, y, z)")
        pivot = self.forward_kinematics(q, self.spec.pivot_link).position_m
        return pivot + quat_to_matrix(quat) @ self._pivot_to_pad_in_body


class _SerialChain:
    """Forward kinematics of a pytorch_kinematics serial chain: one configuration in numpy, a batch
    in torch.

    Per link: ``T[i] = T[i-1] @ (offset[i] @ R(axis[i], theta))`` with the chain's own static
    offsets (link offset @ joint offset) and joint axes, the product pytorch_kinematics'
    ``forward_kinematics_tensor`` forms (``_fk_impl``). The batch form does it in the same order
    with the same rotation formula, so it gives the same bits (``tests/test_kinematics.py``) 1.4-1.6x
    faster (BENCHMARKS.md, "FK composed along the chain"): pytorch_kinematics walks a general tree
    level by level, and the IK calls it tens of thousands of times per run.

    Parameters
    ----------
    chain : pytorch_kinematics.SerialChain
    link_names : sequence of str
        The chain's links, root first.
    inputs : sequence of str
        Joint names in the order of the joint vectors this class is given.
    base : (4, 4) float
        World pose of the chain's root frame.
    """

    def __init__(self, chain, link_names, inputs, base: np.ndarray):
        eye = torch.eye(4, dtype=DTYPE)
        self._offsets, self._joints = [], []
        for name in link_names:
            frame = chain.find_frame(name)
            link_offset = eye if frame.link.offset is None else frame.link.offset.get_matrix()[0].to(DTYPE)
            joint_offset = eye if frame.joint.offset is None else frame.joint.offset.get_matrix()[0].to(DTYPE)
            self._offsets.append((link_offset @ joint_offset).numpy())
            if frame.joint.joint_type == "revolute":
                axis = tuple(float(v) for v in frame.joint.axis)
                self._joints.append((inputs.index(frame.joint.name), axis))
            elif frame.joint.joint_type == "fixed":
                self._joints.append(None)
            else:
                raise ValueError(f"joint {frame.joint.name!r} is {frame.joint.joint_type}: only revolute and fixed")
        self._base = np.asarray(base, dtype=float)
        self._base_t = torch.as_tensor(self._base, dtype=DTYPE)
        self._offsets_t = torch.as_tensor(np.stack(self._offsets), dtype=DTYPE)
        self._revolute = [i for i, joint in enumerate(self._joints) if joint is not None]
        self._revolute_input = torch.tensor([self._joints[i][0] for i in self._revolute], dtype=torch.long)
        self._revolute_axis = torch.tensor([self._joints[i][1] for i in self._revolute], dtype=DTYPE)

    def transform(self, values: list[float], upto: int) -> np.ndarray:
        """World transform (4, 4) of link number ``upto`` for joint values ``values`` (radians)."""
        t = self._base
        for offset, joint in zip(self._offsets[:upto + 1], self._joints[:upto + 1]):
            t = t @ offset
            if joint is not None:
                t = t @ _rotation_44(joint[1], values[joint[0]])
        return t

    def transforms(self, values: torch.Tensor) -> torch.Tensor:
        """World transforms (n_links, B, 4, 4) of every link for joint values (B, n_inputs), radians."""
        batch = values.shape[0]
        rotations = _rotations_44(self._revolute_axis, values[:, self._revolute_input])  # (B, J, 4, 4)
        local = list(self._offsets_t.unbind(0))
        for j, link in enumerate(self._revolute):
            local[link] = local[link] @ rotations[:, j]
        chain = []
        pose = None
        for transform in local:
            pose = transform.expand(batch, 4, 4) if pose is None else pose @ transform
            chain.append(pose)
        return self._base_t @ torch.stack(chain)


def _rotations_44(axes: torch.Tensor, theta: torch.Tensor) -> torch.Tensor:
    """(B, J, 4, 4) rotations by ``theta`` (B, J) about unit ``axes`` (J, 3), pytorch_kinematics'
    formula term for term (``axis_and_angle_to_matrix_33``)."""
    c, s = torch.cos(theta), torch.sin(theta)
    k = 1 - c
    x, y, z = axes.unbind(-1)
    rows = [c + x * x * k, x * y * k - z * s, x * z * k + y * s,
            y * x * k + z * s, c + y * y * k, y * z * k - x * s,
            z * x * k - y * s, z * y * k + x * s, c + z * z * k]
    matrix = torch.zeros(*theta.shape, 4, 4, dtype=theta.dtype)
    matrix[..., :3, :3] = torch.stack(rows, -1).reshape(*theta.shape, 3, 3)
    matrix[..., 3, 3] = 1.0
    return matrix


def _rotation_44(axis: tuple[float, float, float], theta: float) -> np.ndarray:
    """(4, 4) rotation by ``theta`` (rad) about the unit ``axis`` (Rodrigues)."""
    c, s = math.cos(theta), math.sin(theta)
    k = 1.0 - c
    x, y, z = axis
    return np.array([[c + x * x * k, x * y * k - z * s, x * z * k + y * s, 0.0],
                     [y * x * k + z * s, c + y * y * k, y * z * k - x * s, 0.0],
                     [z * x * k - y * s, z * y * k + x * s, c + z * z * k, 0.0],
                     [0.0, 0.0, 0.0, 1.0]])
