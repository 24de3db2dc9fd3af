"""The GPIS potential on a plane through the object, with and without normals side by side."""
from __future__ import annotations

import numpy as np

from reconstruction.figures.canvas import MM_PER_M, check_png_path, new_figure, save_png

#: For each slicing plane: the index of its normal axis and of the (horizontal, vertical) axes.
PLANE_AXES = {"x": (0, (1, 2)), "y": (1, (0, 2)), "z": (2, (0, 1))}

#: Diverging colour map (matplotlib name): f < 0 outside is blue, f > 0 inside is red, 0 is white.
POTENTIAL_COLOUR_MAP = "RdBu_r"

ESTIMATE_STYLE = dict(colors="black", linewidths=1.6)
TRUTH_STYLE = dict(color="#7b2cbf", linestyle="--", linewidth=1.8)


def potential_slice_figure(gpis_with, gpis_without, truth_mesh, plane: str = "z",
                           offset_m: float = 0.0, contact_band_m: float = 3e-3,
                           resolution: int = 160, margin: float = 0.2):
    """The Figure of :func:`potential_slice` (not written)."""
    panels = [(gp, title) for gp, title in ((gpis_with, "with normals"),
                                            (gpis_without, "without normals")) if gp is not None]
    if not panels:
        raise ValueError("both gpis_with and gpis_without are None: nothing to draw")
    if plane not in PLANE_AXES:
        raise ValueError(f"plane must be one of 'x', 'y', 'z', got {plane!r}")
    if not np.isfinite(offset_m):
        raise ValueError(f"offset_m must be finite, got {offset_m}")
    if not contact_band_m >= 0:
        raise ValueError(f"contact_band_m must be >= 0 m, got {contact_band_m}")
    if int(resolution) < 16:
        raise ValueError(f"resolution must be at least 16 samples, got {resolution}")
    normal_axis, (u_axis, v_axis) = PLANE_AXES[plane]
    lo, hi = _scene_box([gp for gp, _ in panels], truth_mesh, margin)
    if not lo[normal_axis] <= offset_m <= hi[normal_axis]:
        raise ValueError(f"offset_m = {offset_m} m puts the {plane}-plane outside the object and its "
                         f"contacts ({lo[normal_axis]:.4f} .. {hi[normal_axis]:.4f} m)")
    u, v, grid = _slice_grid(lo, hi, normal_axis, u_axis, v_axis, offset_m, int(resolution))
    section = _truth_section(truth_mesh, normal_axis, offset_m)

    aspect = (v[-1] - v[0]) / (u[-1] - u[0])
    figure = new_figure(5.2 * len(panels) + 0.4, float(np.clip(4.6 * aspect + 2.4, 3.6, 9.0)),
                        layout="constrained")
    extent_mm = MM_PER_M * np.array([u[0], u[-1], v[0], v[-1]])
    for i, (gp, title) in enumerate(panels):
        ax = figure.add_subplot(1, len(panels), i + 1)
        values = np.asarray(gp.mean(grid.reshape(-1, 3)), float).reshape(len(v), len(u))
        scale, label = (MM_PER_M, "GP mean f (mm, ≈ signed distance near the surface)") \
            if gp.use_normals else (1.0, "GP mean f (unitless, prior +1 inside, −1 outside)")
        values = scale * values
        image = ax.imshow(values, origin="lower", extent=extent_mm, cmap=POTENTIAL_COLOUR_MAP,
                          norm=_centred_norm(values), interpolation="bilinear")
        bar = figure.colorbar(image, ax=ax, orientation="horizontal", fraction=0.05, aspect=30)
        bar.set_ticks(_two_sided_ticks(image.norm.vmin, image.norm.vmax))
        bar.set_label(label, fontsize=9)
        bar.ax.tick_params(labelsize=8)
        if values.min() < 0 < values.max():
            ax.contour(MM_PER_M * u, MM_PER_M * v, values, levels=[0.0], **ESTIMATE_STYLE)
        for polyline in section:
            ax.plot(MM_PER_M * polyline[:, u_axis], MM_PER_M * polyline[:, v_axis], **TRUTH_STYLE)
        shown = _contacts_near_plane(gp, normal_axis, offset_m, contact_band_m)
        _draw_contacts(ax, *shown, u_axis, v_axis, arrow_m=0.08 * float(np.max(hi - lo)))
        ax.set_title(f"{title}: {gp.n_contacts} contacts, {len(shown[0])} within "
                     f"±{MM_PER_M * contact_band_m:g} mm", fontsize=10)
        ax.set_xlabel(f"{'xyz'[u_axis]} (mm)")
        ax.set_ylabel(f"{'xyz'[v_axis]} (mm)")
        ax.set_xlim(extent_mm[:2])
        ax.set_ylim(extent_mm[2:])
        ax.set_aspect("equal")
    _legend(figure, has_truth=bool(section), columns=3 if len(panels) > 1 else 1)
    figure.suptitle(f"GP potential on the plane {plane} = {MM_PER_M * offset_m:.1f} mm "
                    "(red inside, blue outside)", fontsize=11)
    return figure


def potential_slice(gpis_with, gpis_without, truth_mesh, plane: str = "z", offset_m: float = 0.0,
                    path=None, contact_band_m: float = 3e-3, resolution: int = 160,
                    margin: float = 0.2):
    """Write the implicit-surface potential on a slice, one panel per GP.

    Each panel shows the GP's posterior mean ``f`` on the plane in a diverging colour map centred
    at 0 (red inside, ``f > 0``; blue outside), its 0-level as a solid black line, the ground-truth
    cross-section dashed, and the GP's contacts within ``contact_band_m`` of the plane with their
    outward normals projected onto the plane as arrows (a normal across the plane looks short).

    Parameters
    ----------
    gpis_with, gpis_without : reconstruction.gpis.GPIS or None
        Fitted GPs with and without normals (either may be None for one panel), object frame, metres.
    truth_mesh : trimesh.Trimesh or None
        Ground truth, same frame, metres; None draws no cross-section.
    plane : {'x', 'y', 'z'}
        The axis normal to the slice.
    offset_m : float
        Position of the slice along that axis, metres.
    path : str or Path
        PNG file to write.
    contact_band_m : float
        Contacts closer than this to the plane are drawn, metres.
    resolution : int
        Samples along the longer side of the slice.
    margin : float
        The slice covers the truth and the contacts, grown by this fraction of their size per side.

    Returns
    -------
    Path of the PNG written.
    """
    check_png_path(path)
    return save_png(potential_slice_figure(gpis_with, gpis_without, truth_mesh, plane, offset_m,
                                           contact_band_m, resolution, margin), path)


def _centred_norm(values: np.ndarray):
    """White at f = 0; each sign saturates at its own 99th percentile, so a shallow inside and a
    deep outside both show their full colour."""
    from matplotlib.colors import TwoSlopeNorm

    magnitude = max(float(np.percentile(np.abs(values), 99)), 1e-12)
    inside, outside = values[values > 0], -values[values < 0]
    top = float(np.percentile(inside, 99)) if inside.size else magnitude
    bottom = float(np.percentile(outside, 99)) if outside.size else magnitude
    return TwoSlopeNorm(vcenter=0.0, vmin=-max(bottom, 1e-12), vmax=max(top, 1e-12))


def _two_sided_ticks(low: float, high: float) -> np.ndarray:
    """Round colour-bar ticks chosen separately below and above 0 (the two slopes differ)."""
    from matplotlib.ticker import MaxNLocator

    locator = MaxNLocator(3)
    ticks = np.concatenate([locator.tick_values(low, 0.0), locator.tick_values(0.0, high)])
    return np.unique(ticks[(ticks >= low) & (ticks <= high)])


def _scene_box(gps, truth_mesh, margin: float) -> tuple[np.ndarray, np.ndarray]:
    """(lo (3,), hi (3,)) around the truth and every contact, grown by ``margin`` per side, metres."""
    points = [gp.contact_points for gp in gps]
    if truth_mesh is not None:
        points.append(np.asarray(truth_mesh.bounds, float))
    points = np.vstack(points)
    lo, hi = points.min(0), points.max(0)
    pad = margin * max(float(np.max(hi - lo)), 1e-3)
    return lo - pad, hi + pad


def _slice_grid(lo, hi, normal_axis, u_axis, v_axis, offset_m, resolution):
    """Axes u (nu,), v (nv,) and the (nv, nu, 3) grid points on the plane, metres."""
    step = max(hi[u_axis] - lo[u_axis], hi[v_axis] - lo[v_axis]) / (resolution - 1)
    u = np.arange(lo[u_axis], hi[u_axis] + 0.5 * step, step)
    v = np.arange(lo[v_axis], hi[v_axis] + 0.5 * step, step)
    grid = np.zeros((len(v), len(u), 3))
    grid[..., u_axis] = u[None, :]
    grid[..., v_axis] = v[:, None]
    grid[..., normal_axis] = offset_m
    return u, v, grid


def _truth_section(truth_mesh, normal_axis: int, offset_m: float) -> list[np.ndarray]:
    """Polylines (m, 3) of the truth's cross-section by the plane, metres (empty if none)."""
    if truth_mesh is None:
        return []
    normal = np.eye(3)[normal_axis]
    section = truth_mesh.section(plane_normal=normal, plane_origin=normal * offset_m)
    return [] if section is None else [np.asarray(p, float) for p in section.discrete]


def _contacts_near_plane(gp, normal_axis: int, offset_m: float, band_m: float):
    """Contacts (k, 3) within the band and their normals (k, 3) (None for a GP without normals)."""
    points = gp.contact_points
    near = np.abs(points[:, normal_axis] - offset_m) <= band_m
    normals = gp.contact_normals
    return points[near], None if normals is None else normals[near]


def _draw_contacts(ax, points, normals, u_axis, v_axis, arrow_m: float) -> None:
    if not len(points):
        return
    if normals is not None:
        ax.quiver(MM_PER_M * points[:, u_axis], MM_PER_M * points[:, v_axis],
                  MM_PER_M * arrow_m * normals[:, u_axis], MM_PER_M * arrow_m * normals[:, v_axis],
                  angles="xy", scale_units="xy", scale=1.0, color="#222222", width=0.004,
                  zorder=3)
    ax.scatter(MM_PER_M * points[:, u_axis], MM_PER_M * points[:, v_axis], s=18, c="black",
               edgecolors="white", linewidths=0.6, zorder=4)


def _legend(figure, has_truth: bool, columns: int) -> None:
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], color="black", linewidth=1.6, label="GP surface (f = 0)")]
    if has_truth:
        handles.append(Line2D([], [], **TRUTH_STYLE, label="ground-truth section"))
    handles.append(Line2D([], [], color="black", marker="o", linestyle="none", markersize=5,
                          markeredgecolor="white", label="contacts (arrows: outward normal)"))
    figure.legend(handles=handles, loc="outside lower center", ncol=columns, fontsize=9,
                  frameon=False)
