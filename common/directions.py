"""Evenly spread unit directions and frames perpendicular to directions (no units: unit vectors)."""
from __future__ import annotations

import numpy as np


def fibonacci_directions(n: int) -> np.ndarray:
    """(n, 3) unit vectors evenly spread over the sphere (a Fibonacci lattice)."""
    i = np.arange(n) + 0.5
    z = 1 - 2 * i / n
    phi = np.pi * (1 + 5**0.5) * i
    r = np.sqrt(1 - z**2)
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), z])


def perpendicular_frame(directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two (k, 3) unit vectors perpendicular to each of the (k, 3) unit ``directions`` and to each
    other (right-handed with it)."""
    helper = np.where(np.abs(directions[:, :1]) < 0.9, np.array([[1.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]))
    first = np.cross(directions, helper)
    first /= np.linalg.norm(first, axis=1, keepdims=True)
    return first, np.cross(directions, first)
