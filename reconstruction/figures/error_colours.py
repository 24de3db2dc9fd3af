"""Distances between surfaces and their colouring: green for small errors, red for large ones."""
from __future__ import annotations

import numpy as np

from objects.proximity import MeshProximity
from reconstruction.figures.canvas import finite_array

#: Colour map of every error figure (matplotlib name): green (0) -> yellow -> red (max).
ERROR_COLOUR_MAP = "RdYlGn_r"

#: Smallest colour-scale top, metres: keeps a perfect reconstruction from dividing by zero.
MIN_COLOUR_SCALE_M = 1e-4


def error_colours(distances_m, max_error_m: float) -> np.ndarray:
    """RGBA colour of each distance: green at 0, yellow at half ``max_error_m``, red at and above it.

    Parameters
    ----------
    distances_m : (n,) float
        Unsigned distances, metres (>= 0).
    max_error_m : float
        Distance that maps to full red, metres (> 0); larger distances are clipped to red.

    Returns
    -------
    (n, 4) float RGBA in [0, 1].
    """
    distances = finite_array(distances_m, "distances_m", (None,))
    if np.any(distances < 0):
        raise ValueError(f"distances must be >= 0 m, got minimum {distances.min()}")
    if not (np.isfinite(max_error_m) and max_error_m > 0):
        raise ValueError(f"max_error_m must be a positive distance in metres, got {max_error_m!r}")
    return error_colour_map()(np.clip(distances / max_error_m, 0.0, 1.0))


def error_colour_map():
    """The matplotlib Colormap used for errors (looked up lazily, without pyplot)."""
    import matplotlib

    return matplotlib.colormaps[ERROR_COLOUR_MAP]


def colour_scale_m(distances_m: np.ndarray, max_error_m: float | None) -> float:
    """The colour-scale top: ``max_error_m`` if given (> 0), else the largest distance."""
    if max_error_m is None:
        largest = float(np.max(distances_m)) if len(distances_m) else 0.0
        return max(largest, MIN_COLOUR_SCALE_M)
    if not (np.isfinite(max_error_m) and max_error_m > 0):
        raise ValueError(f"max_error_m must be a positive distance in metres, got {max_error_m!r}")
    return float(max_error_m)


def distances_to_surface(points_m, mesh) -> np.ndarray:
    """Unsigned distance from each point to the closest point of ``mesh``.

    Parameters
    ----------
    points_m : (n, 3) float, metres, the mesh's frame
    mesh : trimesh.Trimesh

    Returns
    -------
    (n,) float, metres.
    """
    points = finite_array(points_m, "points_m", (None, 3))
    if len(points) == 0:
        return np.zeros(0)
    return MeshProximity(mesh).query(points)[1]
