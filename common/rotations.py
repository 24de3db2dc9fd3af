"""Quaternion and rotation-matrix helpers (numpy, float64), and the bridge to scipy's Rotation.

Quaternions are (w, x, y, z) unless a name says ``xyzw`` (PyBullet's and scipy's order).
"""
from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation


def as_unit_quat_wxyz(quat_wxyz, name: str = "quaternion") -> np.ndarray:
    """Validate and normalise a (4,) quaternion (w, x, y, z)."""
    quat = np.asarray(quat_wxyz, dtype=float)
    if quat.shape != (4,) or not np.all(np.isfinite(quat)):
        raise ValueError(f"{name} must be 4 finite numbers (w, x, y, z), got {quat_wxyz!r}")
    norm = np.linalg.norm(quat)
    if not 0.9 < norm < 1.1:
        raise ValueError(f"{name} must be a unit quaternion (w, x, y, z), got norm {norm:.3g}")
    return quat / norm


def wxyz_to_xyzw(quat_wxyz) -> np.ndarray:
    """(…, 4) (w, x, y, z) -> (x, y, z, w)."""
    q = np.asarray(quat_wxyz, dtype=float)
    return np.concatenate([q[..., 1:], q[..., :1]], axis=-1)


def xyzw_to_wxyz(quat_xyzw) -> np.ndarray:
    """(…, 4) (x, y, z, w) -> (w, x, y, z)."""
    q = np.asarray(quat_xyzw, dtype=float)
    return np.concatenate([q[..., 3:], q[..., :3]], axis=-1)


def quat_to_matrix(quat_wxyz) -> np.ndarray:
    """(…, 4) unit quaternions (w, x, y, z) -> (…, 3, 3) rotation matrices."""
    q = np.asarray(quat_wxyz, dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    if q.ndim == 1:  # fast path for one quaternion (called every simulation step)
        w, x, y, z = (float(v) for v in q)
        return np.array([
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ])
    w, x, y, z = np.moveaxis(q, -1, 0)
    rows = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ]
    return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


def matrix_to_quat(matrix) -> np.ndarray:
    """(…, 3, 3) rotation matrices -> (…, 4) unit quaternions (w, x, y, z) with w >= 0."""
    m = np.asarray(matrix, dtype=float)
    batch = m.shape[:-2]
    m = m.reshape(-1, 3, 3)
    quats = np.empty((m.shape[0], 4))
    for i, r in enumerate(m):
        trace = np.trace(r)
        if trace > 0.0:
            s = 2.0 * np.sqrt(1.0 + trace)
            quats[i] = [0.25 * s, (r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s]
        else:
            k = int(np.argmax(np.diag(r)))
            j, l = (k + 1) % 3, (k + 2) % 3
            s = 2.0 * np.sqrt(1.0 + r[k, k] - r[j, j] - r[l, l])
            q = np.empty(4)
            q[0] = (r[l, j] - r[j, l]) / s
            q[1 + k] = 0.25 * s
            q[1 + j] = (r[j, k] + r[k, j]) / s
            q[1 + l] = (r[l, k] + r[k, l]) / s
            quats[i] = q
    quats *= np.where(quats[:, :1] < 0.0, -1.0, 1.0)
    quats /= np.linalg.norm(quats, axis=1, keepdims=True)
    return quats.reshape(*batch, 4)


def rotation_angle_between(r_a, r_b) -> np.ndarray:
    """Angle (rad) of the relative rotation between (…, 3, 3) matrices ``r_a`` and ``r_b``."""
    rel = np.swapaxes(np.asarray(r_a, dtype=float), -1, -2) @ np.asarray(r_b, dtype=float)
    cos = (np.trace(rel, axis1=-2, axis2=-1) - 1.0) / 2.0
    return np.arccos(np.clip(cos, -1.0, 1.0))


def angle_between_vectors(u, v) -> np.ndarray:
    """Angle (rad) between (…, 3) vectors, robust near 0 and pi."""
    u = np.asarray(u, dtype=float)
    v = np.asarray(v, dtype=float)
    cross = np.linalg.norm(np.cross(u, v), axis=-1)
    dot = np.sum(u * v, axis=-1)
    return np.arctan2(cross, dot)


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


# ---- one rotation at a time, in plain floats --------------------------------------------------
# Simulated chips compose a few rotations per sample; numpy and scipy cost microseconds of call
# overhead per operation on 4-vectors, plain float arithmetic a fraction of that.
# tests/test_rotations_fast.py checks these against scipy's Rotation on random inputs.

def quat_multiply_wxyz(a, b) -> tuple[float, float, float, float]:
    """Hamilton product ``a * b`` of (w, x, y, z) quaternions: the rotation ``b`` then ``a``.

    Parameters
    ----------
    a, b : sequence of 4 float, (w, x, y, z)

    Returns
    -------
    tuple of 4 float, (w, x, y, z); unit when both inputs are.
    """
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw)


def quat_from_rotvec_wxyz(x: float, y: float, z: float) -> tuple[float, float, float, float]:
    """Unit quaternion (w, x, y, z), w >= 0, of the rotation vector (x, y, z) (axis times angle, rad)."""
    angle = (x * x + y * y + z * z) ** 0.5
    if angle < 1e-3:  # Taylor series of sin(angle / 2) / angle; exact to float64 below 1e-3 rad
        angle2 = angle * angle
        scale = 0.5 - angle2 / 48.0 + angle2 * angle2 / 3840.0
    else:
        scale = math.sin(0.5 * angle) / angle
    return (math.cos(0.5 * angle), x * scale, y * scale, z * scale)


def quat_normalised_wxyz(q) -> tuple[float, float, float, float]:
    """(w, x, y, z) divided by its norm, as floats."""
    w, x, y, z = q.tolist() if isinstance(q, np.ndarray) else (float(v) for v in q)
    norm = (w * w + x * x + y * y + z * z) ** 0.5
    return (w / norm, x / norm, y / norm, z / norm)


def quat_rotate_inverse_wxyz(q, v) -> tuple[float, float, float]:
    """``R(q)^T v``: a world-frame vector in the frame that unit quaternion ``q`` (w, x, y, z) rotates to world.

    Parameters
    ----------
    q : sequence of 4 float, unit (w, x, y, z)
    v : sequence of 3 float

    Returns
    -------
    tuple of 3 float
    """
    w, x, y, z = q
    vx, vy, vz = v
    # v' = v + w t + u x t with u = -(x, y, z) (the conjugate) and t = 2 u x v
    x, y, z = -x, -y, -z
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return (vx + w * tx + (y * tz - z * ty),
            vy + w * ty + (z * tx - x * tz),
            vz + w * tz + (x * ty - y * tx))
