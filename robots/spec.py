"""RobotSpec: the data that describes one arm with a compliant tactile fingertip."""
from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, fields
from pathlib import Path

import numpy as np

from robots.fingertip import (
    DEFAULT_SPRING_DAMPING_NMS_PER_RAD,
    DEFAULT_SPRING_STIFFNESS_NM_PER_RAD,
    PAD_LINK,
    PIVOT_LINK,
    SENSOR_BODY_LINK,
    SPRING_JOINTS,
    TOOL_LINK,
)
from common.rotations import as_unit_quat_wxyz

DEFAULT_PAD_LATERAL_FRICTION = 0.4
DEFAULT_PAD_CONTACT_STIFFNESS_N_PER_M = 2.0e4
DEFAULT_PAD_CONTACT_DAMPING_NS_PER_M = 40.0
# Assumption (no measurement found): a load on the pad's side wall shears the polyurethane and
# raises the pressure over the barometer by about a tenth of what the same load on the face does.
DEFAULT_PAD_SIDE_PRESSURE_GAIN = 0.1


def _floats(values, name: str, length: int | None = None) -> tuple[float, ...]:
    array = np.asarray(values, dtype=float).reshape(-1)
    if length is not None and array.shape != (length,):
        raise ValueError(f"{name} must have {length} values, got {len(array)}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite, got {values!r}")
    return tuple(float(v) for v in array)


@dataclass(frozen=True)
class RobotSpec:
    """A robot arm with the compliant fingertip: names and defaults, no simulator state.

    Attributes
    ----------
    name : str
    urdf_path : Path
        The URDF used by both the simulator and the kinematics.
    joint_names : tuple of str
        Actuated joints, in the order of every joint vector (``q``) in this package.
    home_q_rad : tuple of float
        Home configuration, radians, same order as ``joint_names``.
    base_position_m : (3,) float
        World position of the URDF root link frame, metres.
    base_quat_wxyz : (4,) float
        World orientation of the URDF root link frame.
    tool_link, pivot_link, sensor_body_link, pad_link : str
        Link names: the arm's tool point, the spring pivot, the rigid sensor body (its +z is the
        pad's outward normal) and the pad face centre frame.
    spring_joint_names : (2,) str
        The passive spring joints, pivot side first; their axes must meet at the pivot origin.
    spring_stiffness_nm_per_rad, spring_damping_nms_per_rad : float
        Default spring law ``tau = -k theta - c theta_dot`` per spring joint.
    pad_lateral_friction : float
        Coulomb friction coefficient of the pad.
    pad_contact_stiffness_n_per_m, pad_contact_damping_ns_per_m : float
        Contact softness of the polyurethane pad, per contact point (PyBullet's contact model).
    pad_side_pressure_gain : float
        What the barometer feels of a contact force's component across the pad's face axis, as a
        fraction of the component along it, in [0, 1]: the pad's side feels a push that little
        (an assumption, ``DEFAULT_PAD_SIDE_PRESSURE_GAIN``).
    workspace_center_m : (3,) float
        A point in front of the robot where table-top objects are reachable, world frame, metres.
    """

    name: str
    urdf_path: Path
    joint_names: tuple[str, ...]
    home_q_rad: tuple[float, ...]
    base_position_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    base_quat_wxyz: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    tool_link: str = TOOL_LINK
    pivot_link: str = PIVOT_LINK
    sensor_body_link: str = SENSOR_BODY_LINK
    pad_link: str = PAD_LINK
    spring_joint_names: tuple[str, str] = SPRING_JOINTS
    spring_stiffness_nm_per_rad: float = DEFAULT_SPRING_STIFFNESS_NM_PER_RAD
    spring_damping_nms_per_rad: float = DEFAULT_SPRING_DAMPING_NMS_PER_RAD
    pad_lateral_friction: float = DEFAULT_PAD_LATERAL_FRICTION
    pad_contact_stiffness_n_per_m: float = DEFAULT_PAD_CONTACT_STIFFNESS_N_PER_M
    pad_contact_damping_ns_per_m: float = DEFAULT_PAD_CONTACT_DAMPING_NS_PER_M
    pad_side_pressure_gain: float = DEFAULT_PAD_SIDE_PRESSURE_GAIN
    workspace_center_m: tuple[float, float, float] = (0.5, 0.0, 0.8)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"robot name must be a non-empty string, got {self.name!r}")
        set_(self, "urdf_path", Path(self.urdf_path))
        set_(self, "joint_names", tuple(str(n) for n in self.joint_names))
        if not self.joint_names:
            raise ValueError(f"robot {self.name!r}: joint_names is empty")
        if len(set(self.joint_names)) != len(self.joint_names):
            raise ValueError(f"robot {self.name!r}: duplicate joint names {self.joint_names}")
        set_(self, "home_q_rad", _floats(self.home_q_rad, "home_q_rad", len(self.joint_names)))
        set_(self, "base_position_m", _floats(self.base_position_m, "base_position_m", 3))
        set_(self, "base_quat_wxyz", tuple(float(v) for v in as_unit_quat_wxyz(self.base_quat_wxyz, "base_quat_wxyz")))
        set_(self, "workspace_center_m", _floats(self.workspace_center_m, "workspace_center_m", 3))
        springs = tuple(str(n) for n in self.spring_joint_names)
        if len(springs) != 2 or springs[0] == springs[1]:
            raise ValueError(f"robot {self.name!r}: need two distinct spring joint names, got {springs}")
        if set(springs) & set(self.joint_names):
            raise ValueError(f"robot {self.name!r}: spring joints {springs} must not be actuated joints")
        set_(self, "spring_joint_names", springs)
        for field_name in ("spring_stiffness_nm_per_rad", "pad_contact_stiffness_n_per_m"):
            value = float(getattr(self, field_name))
            if not value > 0.0 or not math.isfinite(value):
                raise ValueError(f"robot {self.name!r}: {field_name} must be positive, got {value}")
            set_(self, field_name, value)
        for field_name in ("spring_damping_nms_per_rad", "pad_lateral_friction", "pad_contact_damping_ns_per_m"):
            value = float(getattr(self, field_name))
            if not value >= 0.0 or not math.isfinite(value):
                raise ValueError(f"robot {self.name!r}: {field_name} must be >= 0, got {value}")
            set_(self, field_name, value)
        gain = float(self.pad_side_pressure_gain)
        if not 0.0 <= gain <= 1.0:
            raise ValueError(f"robot {self.name!r}: pad_side_pressure_gain must be in [0, 1], got {gain}")
        set_(self, "pad_side_pressure_gain", gain)

    @property
    def dof(self) -> int:
        """Number of actuated joints."""
        return len(self.joint_names)

    @property
    def home_q(self) -> np.ndarray:
        """Home configuration as a (dof,) float array, radians."""
        return np.array(self.home_q_rad)

    def to_json(self, path: Path) -> None:
        """Write the spec as JSON; ``urdf_path`` is stored relative to the file when possible."""
        path = Path(path)
        data = asdict(self)
        urdf = Path(self.urdf_path).resolve()
        try:
            data["urdf_path"] = str(urdf.relative_to(path.resolve().parent))
        except ValueError:
            data["urdf_path"] = str(urdf)
        path.write_text(json.dumps(data, indent=2) + "\n")

    @classmethod
    def from_json(cls, path: Path) -> "RobotSpec":
        """Read a spec written by :meth:`to_json` (relative ``urdf_path`` is relative to the file)."""
        path = Path(path)
        try:
            data = json.loads(path.read_text())
        except FileNotFoundError:
            raise FileNotFoundError(f"robot spec file not found: {path}") from None
        except json.JSONDecodeError as err:
            raise ValueError(f"robot spec {path} is not valid JSON: {err}") from None
        if not isinstance(data, dict):
            raise ValueError(f"robot spec {path} must hold a JSON object")
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ValueError(f"robot spec {path}: unknown fields {unknown}; known: {sorted(known)}")
        missing = sorted(k for k in ("name", "urdf_path", "joint_names", "home_q_rad") if k not in data)
        if missing:
            raise ValueError(f"robot spec {path}: missing required fields {missing}")
        urdf = Path(data["urdf_path"])
        if not urdf.is_absolute():
            urdf = path.resolve().parent / urdf
        data["urdf_path"] = urdf
        return cls(**data)
