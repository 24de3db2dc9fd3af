"""Headless figure creation and PNG writing, without pyplot or a global backend switch.

Every figure in this package is a plain :class:`matplotlib.figure.Figure` attached to its own
:class:`~matplotlib.backends.backend_agg.FigureCanvasAgg`, so rendering works without a display and
leaves ``matplotlib.pyplot``'s state (and any backend other code selected) untouched.
"""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from common.atomic_files import write_bytes_atomically

#: Resolution of every PNG written, dots per inch.
DPI = 120

#: Metres to millimetres, for axes and colour bars (code stays in SI units).
MM_PER_M = 1e3


def new_figure(width_in: float, height_in: float, layout: str | None = None):
    """A Figure of the given size in inches with its own Agg canvas (no pyplot).

    ``layout="constrained"`` lets matplotlib place colour bars and outside legends.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure(figsize=(width_in, height_in), dpi=DPI, layout=layout)
    FigureCanvasAgg(figure)
    return figure


def check_png_path(path) -> Path:
    """``path`` as a Path ending in ``.png``; ValueError otherwise."""
    if path is None:
        raise ValueError("a PNG path is required, got None")
    path = Path(path)
    if path.suffix.lower() != ".png":
        raise ValueError(f"figures are written as PNG; the path must end in .png, got {str(path)!r}")
    return path


def save_png(figure, path) -> Path:
    """Write ``figure`` to ``path`` whole or not at all (creating missing parent folders); returns the path."""
    path = check_png_path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    png = io.BytesIO()
    figure.savefig(png, format="png", dpi=DPI)
    return write_bytes_atomically(path, png.getvalue())


def rendered_rgba(figure) -> np.ndarray:
    """The figure drawn to its canvas as a (height, width, 4) uint8 RGBA array, row 0 at the top."""
    figure.canvas.draw()
    return np.asarray(figure.canvas.buffer_rgba()).copy()


def finite_array(value, name: str, shape: tuple) -> np.ndarray:
    """``value`` as a float array of ``shape`` (None: any length), all finite; ValueError otherwise."""
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be numeric, got {type(value).__name__}") from exc
    if array.ndim != len(shape) or any(s is not None and a != s for a, s in zip(array.shape, shape)):
        sizes = ["n" if s is None else str(s) for s in shape]
        want = f"({sizes[0]},)" if len(sizes) == 1 else "(" + ", ".join(sizes) + ")"
        raise ValueError(f"{name} must have shape {want}, got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} contain NaN or inf")
    return array
