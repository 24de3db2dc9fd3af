"""Normal-estimation error against the tilt of the touched surface."""
from __future__ import annotations

import numpy as np

from reconstruction.figures.canvas import check_png_path, finite_array, new_figure, save_png


def tilt_groups(tilts_deg, errors_deg) -> list[tuple[float, np.ndarray]]:
    """Errors grouped by tilt: [(tilt_deg, errors_deg (m,)), ...] in increasing tilt.

    Parameters
    ----------
    tilts_deg : (n,) float
        Tilt of the surface for each trial, degrees.
    errors_deg : (n,) float
        Angle between the measured and the true normal for each trial, degrees (>= 0).
    """
    tilts = finite_array(tilts_deg, "tilts_deg", (None,))
    errors = finite_array(errors_deg, "errors_deg", (len(tilts),))
    if len(tilts) == 0:
        raise ValueError("no trials: tilts_deg and errors_deg are empty")
    if np.any(errors < 0):
        raise ValueError(f"errors_deg are angles between normals and must be >= 0, "
                         f"got minimum {errors.min()}")
    return [(float(tilt), errors[tilts == tilt]) for tilt in np.unique(tilts)]


def normal_error_vs_tilt_figure(tilts_deg, errors_deg, reference_deg: float | None = None):
    """The Figure of :func:`normal_error_vs_tilt` (not written)."""
    groups = tilt_groups(tilts_deg, errors_deg)
    if reference_deg is not None and not (np.isfinite(reference_deg) and reference_deg >= 0):
        raise ValueError(f"reference_deg must be a finite angle >= 0, got {reference_deg!r}")
    tilts = np.array([tilt for tilt, _ in groups])
    spacing = float(np.min(np.diff(tilts))) if len(tilts) > 1 else 10.0
    figure = new_figure(7.5, 4.8, layout="constrained")
    ax = figure.add_subplot()
    ax.boxplot([errors for _, errors in groups], positions=tilts, widths=0.5 * spacing,
               whis=(5, 95), showfliers=True, manage_ticks=False,
               flierprops=dict(marker=".", markersize=3, markerfacecolor="#888888",
                               markeredgecolor="none"),
               medianprops=dict(color="#1f3b73"), boxprops=dict(color="#1f3b73"),
               whiskerprops=dict(color="#1f3b73"), capprops=dict(color="#1f3b73"))
    means = np.array([errors.mean() for _, errors in groups])
    rmse = np.array([np.sqrt(np.mean(errors**2)) for _, errors in groups])
    ax.plot(tilts, means, "D", color="#d62728", markersize=5, label="mean per tilt", gid="mean")
    ax.plot(tilts, rmse, "x", color="black", markersize=6, label="RMSE per tilt", gid="rmse")
    overall = float(np.mean(np.concatenate([errors for _, errors in groups])))
    ax.axhline(overall, color="#d62728", linewidth=1.2, gid="overall-mean",
               label=f"mean over all {sum(len(e) for _, e in groups)} trials: {overall:.1f}°")
    if reference_deg is not None:
        ax.axhline(reference_deg, color="#2ca02c", linestyle="--", linewidth=1.4, gid="reference",
                   label=f"reference sensor, reported mean over 0-50°: {reference_deg:.1f}°")
    ax.set_xlim(tilts[0] - 0.75 * spacing, tilts[-1] + 0.75 * spacing)
    ax.set_ylim(bottom=0)
    ax.set_xlabel("surface tilt (°)")
    ax.set_ylabel("normal error (°)")
    ax.set_title("Normal error per tilt (box: quartiles and median, whiskers: 5–95 %)", fontsize=10)
    ax.grid(True, axis="y", alpha=0.3)
    ax.legend(fontsize=9, loc="upper left")
    return figure


def normal_error_vs_tilt(tilts_deg, errors_deg, path, reference_deg: float | None = None):
    """Write the normal error against surface tilt: a box per tilt, mean and RMSE markers.

    Parameters
    ----------
    tilts_deg : (n,) float
        Tilt of the touched surface for each trial, degrees; trials with equal tilt form one box.
    errors_deg : (n,) float
        Angle between measured and true normal for each trial, degrees (>= 0).
    path : str or Path
        PNG file to write.
    reference_deg : float, optional
        A reference error (e.g. a published figure) drawn as a dashed line, degrees.

    Returns
    -------
    Path of the PNG written.
    """
    check_png_path(path)
    return save_png(normal_error_vs_tilt_figure(tilts_deg, errors_deg, reference_deg), path)
