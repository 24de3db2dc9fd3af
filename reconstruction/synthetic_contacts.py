"""Contacts sampled from a ground-truth mesh with a sensor-like noise model.

Stands in for the robot when only the reconstruction is under test (the reference accuracy table,
unit tests). The defaults describe the real fingertip sensor:

* ``normal_std_m = 0.2 mm`` along the surface normal: the 3.7 mm polyurethane pad (about
  0.3 MPa) compresses by 0.02-0.1 mm at the 0.5-2 N contact forces used, and the pad-face centre
  computed from the arm's encoders and the IMU carries joint-angle resolution errors of the same
  order;
* ``tangent_std_m = 1.0 mm`` along the surface: where on the 18 mm pad face the object touches is
  not measured (on a flat or gently curved surface this barely moves the point off the surface);
* ``normal_error_mean_deg = 7.0``: the mean angle between the IMU-measured face axis and the true
  normal reported for the sensor over tilts of 0-50 deg (7.3 deg). The error direction is uniform
  around the normal and its size Rayleigh-distributed, so the mean angle is this value.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ContactNoise:
    """Noise added to sampled contacts.

    Attributes
    ----------
    normal_std_m : float
        Standard deviation of the position error along the true surface normal, metres.
    tangent_std_m : float
        Standard deviation of the position error along each tangent direction, metres.
    normal_error_mean_deg : float
        Mean angle between the reported and the true normal, degrees.
    """

    normal_std_m: float = 0.2e-3
    tangent_std_m: float = 1.0e-3
    normal_error_mean_deg: float = 7.0

    def __post_init__(self):
        if min(self.normal_std_m, self.tangent_std_m, self.normal_error_mean_deg) < 0:
            raise ValueError(f"noise levels must be >= 0, got {self}")

    @classmethod
    def off(cls) -> "ContactNoise":
        return cls(0.0, 0.0, 0.0)


def sample_contacts(mesh, n: int, noise: ContactNoise = ContactNoise(), seed: int = 0,
                    pool: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Area-uniform contacts on ``mesh`` with noise.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Ground truth, object frame, metres, outward normals.
    n : int
        Number of contacts.
    pool : int, optional
        Draw a seeded sequence of ``pool`` contacts and return its first ``n``: with the same seed
        and pool, more contacts extend fewer, as an exploration's do (nested draws; ``n <= pool``).
        None: ``n`` contacts drawn on their own (a draw of 200 does not contain the draw of 100).

    Returns
    -------
    points : (n, 3) float, noisy positions, metres
    normals : (n, 3) float, noisy outward unit normals
    true_points : (n, 3) float
    true_normals : (n, 3) float
    """
    if n < 1:
        raise ValueError(f"need at least one contact, got n={n}")
    if pool is not None:
        if pool < n:
            raise ValueError(f"a pool of {pool} contacts cannot give {n}: give pool >= n")
        return tuple(a[:n] for a in sample_contacts(mesh, pool, noise, seed))
    from objects.sampling import sample_surface

    rng = np.random.default_rng(seed)
    true_points, faces = sample_surface(mesh, n, rng)
    true_normals = mesh.face_normals[faces]
    points, normals = add_contact_noise(true_points, true_normals, noise, rng)
    return points, normals, true_points, true_normals


def add_contact_noise(true_points: np.ndarray, true_normals: np.ndarray, noise: ContactNoise,
                      rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """``noise`` applied to exact contacts (``sample_contacts``' model, for contacts chosen elsewhere).

    Parameters
    ----------
    true_points, true_normals : (n, 3) float
        Exact surface points (metres) and outward unit normals, one frame.

    Returns
    -------
    points : (n, 3) float, metres
    normals : (n, 3) float, unit
    """
    n = len(true_points)
    tangent_a = np.cross(true_normals, rng.normal(size=(n, 3)))
    tangent_a /= np.linalg.norm(tangent_a, axis=1, keepdims=True)
    tangent_b = np.cross(true_normals, tangent_a)
    points = (true_points
              + true_normals * rng.normal(scale=noise.normal_std_m, size=(n, 1))
              + tangent_a * rng.normal(scale=noise.tangent_std_m, size=(n, 1))
              + tangent_b * rng.normal(scale=noise.tangent_std_m, size=(n, 1)))
    normals = perturb_normals(true_normals, noise.normal_error_mean_deg, rng)
    return points, normals


def sphere_contacts(n: int, radius_m: float = 0.05, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Exact contacts on a sphere centred at the origin (the closed-form case of tests and examples).

    Returns
    -------
    points : (n, 3) float, metres; normals : (n, 3) float, outward unit normals.
    Directions are Gaussian draws normalised (uniform on the sphere), seeded.
    """
    normals = np.random.default_rng(seed).normal(size=(n, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    return radius_m * normals, normals


def perturb_normals(normals: np.ndarray, mean_error_deg: float, rng: np.random.Generator) -> np.ndarray:
    """Tilt each (n, 3) unit normal by a Rayleigh-distributed angle with the given mean."""
    if mean_error_deg == 0:
        return normals.copy()
    sigma = np.radians(mean_error_deg) / np.sqrt(np.pi / 2)
    angle = rng.rayleigh(sigma, size=len(normals))
    axis = np.cross(normals, rng.normal(size=normals.shape))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    # Rodrigues with axis orthogonal to the normal: n cos(a) + (axis x n) sin(a)
    tilted = normals * np.cos(angle)[:, None] + np.cross(axis, normals) * np.sin(angle)[:, None]
    return tilted / np.linalg.norm(tilted, axis=1, keepdims=True)
