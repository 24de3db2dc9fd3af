"""(w, x, y, z) quaternions, the order every Reading uses, bridged to scipy's Rotation ((x, y, z, w))."""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation


def rotation_from_wxyz(quat_wxyz) -> Rotation:
    """scipy Rotation from (w, x, y, z) quaternion(s), shape (4,) or (n, 4); normalised by scipy."""
    q = np.asarray(quat_wxyz, dtype=float)
    if q.shape[-1] != 4 or q.ndim > 2:
        raise ValueError(f"quaternions must have shape (4,) or (n, 4), got {q.shape}")
    return Rotation.from_quat(q[..., [1, 2, 3, 0]])


def wxyz_from_rotation(rotation: Rotation) -> np.ndarray:
    """(w, x, y, z) quaternion(s) of a scipy Rotation, shape (4,) or (n, 4)."""
    return rotation.as_quat()[..., [3, 0, 1, 2]]


def angle_between_rad(quat_a_wxyz, quat_b_wxyz) -> float:
    """Angle of the rotation taking orientation a to orientation b, radians in [0, pi]; sign-blind."""
    a = np.asarray(quat_a_wxyz, dtype=float)
    b = np.asarray(quat_b_wxyz, dtype=float)
    cosine = abs(float(np.dot(a, b))) / (np.linalg.norm(a) * np.linalg.norm(b))
    return 2.0 * float(np.arccos(min(1.0, cosine)))
