"""Reconstruction error against the number of touches, one curve per exploration strategy."""
from __future__ import annotations

from typing import Mapping

import numpy as np

from reconstruction.figures.canvas import MM_PER_M, check_png_path, finite_array, new_figure, save_png

BANDS = ("minmax", "std")


def curve_summary(errors, band: str = "minmax") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean over seeds and the band around it for one strategy.

    Parameters
    ----------
    errors : (seeds, touches) float
        Error after each touch for each seed.
    band : {'minmax', 'std'}
        Band limits: the min and max over seeds, or the mean +- one standard deviation.

    Returns
    -------
    mean, lower, upper : (touches,) float, in the units of ``errors``.
    """
    if band not in BANDS:
        raise ValueError(f"band must be one of {BANDS}, got {band!r}")
    errors = finite_array(errors, "errors", (None, None))
    if errors.size == 0:
        raise ValueError(f"errors must hold at least one seed and one touch, got shape {errors.shape}")
    mean = errors.mean(0)
    if band == "minmax":
        return mean, errors.min(0), errors.max(0)
    spread = errors.std(0)
    return mean, mean - spread, mean + spread


def error_vs_touches_figure(curves: Mapping[str, np.ndarray], ylabel: str = "position RMSE (mm)",
                            scale: float = MM_PER_M, band: str = "minmax", log_y: bool = False,
                            touches=None):
    """The Figure of :func:`error_vs_touches` (not written)."""
    if not isinstance(curves, Mapping) or not curves:
        raise ValueError("curves must be a non-empty dict strategy name -> (seeds, touches) errors")
    if not (np.isfinite(scale) and scale > 0):
        raise ValueError(f"scale must be a positive factor, got {scale!r}")
    summaries = {}
    for name, errors in curves.items():
        try:
            summaries[name] = curve_summary(errors, band)
        except ValueError as exc:
            raise ValueError(f"strategy {name!r}: {exc}") from exc
    figure = new_figure(7.5, 4.8, layout="constrained")
    ax = figure.add_subplot()
    colours = _palette(len(summaries))
    for (name, (mean, lower, upper)), colour in zip(summaries.items(), colours):
        x = np.arange(1, len(mean) + 1) if touches is None else np.asarray(touches, float)
        if len(x) != len(mean):
            raise ValueError(f"touches has {len(x)} values, strategy {name!r} has {len(mean)} columns")
        seeds = len(np.atleast_2d(curves[name]))
        ax.fill_between(x, scale * lower, scale * upper, color=colour, alpha=0.2, linewidth=0,
                        gid=f"band:{name}")
        ax.plot(x, scale * mean, color=colour, linewidth=1.8, gid=f"mean:{name}",
                label=f"{name} ({seeds} seeds)")
    if log_y:
        ax.set_yscale("log")
    else:
        ax.set_ylim(bottom=0)
    ax.set_xlim(left=1)
    ax.set_xlabel("touches")
    ax.set_ylabel(ylabel)
    band_text = "min–max over seeds" if band == "minmax" else "±1 std over seeds"
    ax.set_title(f"Error against touches (line: mean, band: {band_text})", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=9)
    return figure


def error_vs_touches(curves: Mapping[str, np.ndarray], path, ylabel: str = "position RMSE (mm)",
                     scale: float = MM_PER_M, band: str = "minmax", log_y: bool = False,
                     touches=None):
    """Write one curve per strategy: the mean error over seeds after each touch, with a band.

    Parameters
    ----------
    curves : dict str -> (seeds, touches) float
        Per strategy, the error after touch 1, 2, ... for each seed, in SI units (metres for
        positions, radians for angles). Strategies may have different numbers of touches.
    path : str or Path
        PNG file to write.
    ylabel : str
        Label of the error axis, with the displayed unit.
    scale : float
        Factor from the SI values to the displayed unit: 1000 (metres -> mm, the default),
        ``180 / pi`` for radians -> degrees, 1 to plot as given.
    band : {'minmax', 'std'}
        Band of min-max over seeds, or mean +- one standard deviation.
    log_y : bool
        Logarithmic error axis.
    touches : (k,) float, optional
        Touch counts of the columns (default 1, 2, ..., k), for errors evaluated every few touches.

    Returns
    -------
    Path of the PNG written.
    """
    check_png_path(path)
    return save_png(error_vs_touches_figure(curves, ylabel, scale, band, log_y, touches), path)


def _palette(n: int) -> list:
    import matplotlib

    colours = matplotlib.colormaps["tab10"].colors
    return [colours[i % len(colours)] for i in range(n)]
