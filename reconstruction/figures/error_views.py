"""3D views of a reconstruction coloured by its error, and of the truth's sharp edges likewise.

Drawn with matplotlib's mplot3d, which sorts polygons back to front per collection (a painter's
algorithm). Faces turned away from the camera are dropped before drawing: that halves the work and
keeps the far side of the object from showing through where the depth sort fails. Contacts are
shown only where the reconstruction under them faces the camera, for the same reason.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from objects.features import SHARP_ANGLE_RAD, sharp_edges
from objects.proximity import MeshProximity
from reconstruction.figures.canvas import MM_PER_M, check_png_path, finite_array, new_figure, save_png
from reconstruction.figures.error_colours import (colour_scale_m, distances_to_surface, error_colour_map,
                                                  error_colours)
from reconstruction.figures.simplify import simplify_to

DEFAULT_VIEWS = ((30.0, 45.0), (30.0, 225.0), (-30.0, 135.0))

#: Longest piece a sharp edge is cut into before colouring, metres (colour varies along long edges).
EDGE_PIECE_M = 1e-3

#: Brightness range of the Lambert shading applied on top of the error colours (hue unchanged).
SHADING = (0.7, 1.0)


def view_direction(elevation_deg: float, azimuth_deg: float) -> np.ndarray:
    """(3,) unit vector from the scene towards matplotlib's camera for ``view_init(elev, azim)``."""
    elevation, azimuth = np.radians(elevation_deg), np.radians(azimuth_deg)
    return np.array([np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth),
                     np.sin(elevation)])


def error_coloured_views_figure(reconstruction, truth, contacts_m,
                                views: Sequence[Sequence[float]] = DEFAULT_VIEWS,
                                max_error_m: float | None = None, max_faces: int = 3000):
    """The Figure of :func:`error_coloured_views` (not written)."""
    _check_mesh(reconstruction, "reconstruction")
    _check_mesh(truth, "truth")
    contacts = finite_array(contacts_m, "contacts_m", (None, 3))
    views = _check_views(views)
    # Errors are measured at the full-resolution vertices, then averaged onto the drawn faces,
    # so simplification changes the picture's detail but not the numbers.
    vertex_errors = distances_to_surface(reconstruction.vertices, truth)
    full_faces = np.asarray(reconstruction.faces)
    full_face_errors = vertex_errors[full_faces].mean(1)
    vertices, faces, cluster = simplify_to(reconstruction.vertices, full_faces, max_faces)
    merged_errors = (np.bincount(cluster, weights=vertex_errors, minlength=len(vertices))
                     / np.maximum(np.bincount(cluster, minlength=len(vertices)), 1))
    face_errors = merged_errors[faces].mean(1)
    triangles = vertices[faces]
    scale = colour_scale_m(vertex_errors, max_error_m)
    colours = error_colours(face_errors, scale)
    normals = _unit_normals(triangles)
    contact_normals = _normals_under(contacts, triangles, normals)
    limits = _axis_limits(np.vstack([vertices, contacts]))

    figure, axes = _view_grid(views, limits)
    for ax, view in zip(axes, views):
        eye = view_direction(*view)
        front = normals @ eye > 0
        _add_surface(ax, triangles[front], _shade(colours[front], normals[front], eye))
        visible = contacts[contact_normals @ eye > 0]
        if len(visible):
            ax.scatter(*(MM_PER_M * visible.T), s=7, c="black", depthshade=False, zorder=2,
                       label="contacts")
    _error_colour_bar(figure, axes, scale, "distance to ground truth (mm)")
    area = _triangle_areas(np.asarray(reconstruction.vertices, float)[full_faces])
    mean_mm = MM_PER_M * float(np.sum(area * full_face_errors) / max(np.sum(area), 1e-30))
    figure.suptitle(f"Reconstruction coloured by distance to ground truth: area-weighted mean "
                    f"{mean_mm:.2f} mm, max {MM_PER_M * vertex_errors.max():.2f} mm, "
                    f"{len(contacts)} contacts (black)", fontsize=11)
    return figure


def error_coloured_views(reconstruction, truth, contacts_m, path,
                         views: Sequence[Sequence[float]] = DEFAULT_VIEWS,
                         max_error_m: float | None = None, max_faces: int = 3000):
    """Write the reconstruction, coloured by its distance to the ground truth, from a few viewpoints.

    Colours show the distance from the reconstruction's vertices to the closest point of
    ``truth`` (averaged over each drawn face): green at 0, yellow at half the scale, red at
    ``max_error_m`` and above; a colour bar shows the scale in mm. Contacts are black dots. The
    title gives the area-weighted mean and the largest distance of the full-resolution mesh.

    Parameters
    ----------
    reconstruction : trimesh.Trimesh
        Reconstructed surface (e.g. ``GPIS.mesh()``), object frame, metres. Simplified by vertex
        clustering to at most ``max_faces`` faces before drawing.
    truth : trimesh.Trimesh
        Ground truth, same frame, metres.
    contacts_m : (n, 3) float
        Contact positions, same frame, metres (n may be 0).
    path : str or Path
        PNG file to write (parent folders are created).
    views : sequence of (elevation_deg, azimuth_deg)
        One panel per viewpoint, matplotlib's ``view_init`` convention.
    max_error_m : float, optional
        Distance shown as full red, metres; defaults to the largest vertex error.
    max_faces : int
        Face budget per view before simplification.

    Returns
    -------
    Path of the PNG written.
    """
    check_png_path(path)
    return save_png(error_coloured_views_figure(reconstruction, truth, contacts_m, views,
                                                max_error_m, max_faces), path)


def edge_error_view_figure(truth, reconstruction, edges_m=None,
                           views: Sequence[Sequence[float]] = DEFAULT_VIEWS,
                           max_error_m: float | None = None, min_angle_rad: float = SHARP_ANGLE_RAD,
                           max_faces: int = 3000):
    """The Figure of :func:`edge_error_view` (not written)."""
    _check_mesh(truth, "truth")
    _check_mesh(reconstruction, "reconstruction")
    views = _check_views(views)
    if edges_m is None:
        edges_m = sharp_edges(truth, min_angle_rad)
    edges = finite_array(edges_m, "edges_m", (None, 2, 3))
    if len(edges) == 0:
        raise ValueError("the truth has no sharp edges to show (edges_m is empty); lower "
                         "min_angle_rad or pass edges_m")
    pieces, piece_errors = edge_piece_errors(edges, reconstruction)
    scale = colour_scale_m(piece_errors, max_error_m)
    colours = error_colours(piece_errors, scale)
    vertices, faces, _ = simplify_to(reconstruction.vertices, reconstruction.faces, max_faces)
    triangles = vertices[faces]
    normals = _unit_normals(triangles)
    limits = _axis_limits(np.vstack([vertices, edges.reshape(-1, 3)]))

    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    figure, axes = _view_grid(views, limits)
    for ax, view in zip(axes, views):
        eye = view_direction(*view)
        front = normals @ eye > 0
        grey = np.tile([0.75, 0.75, 0.75, 0.35], (int(front.sum()), 1))
        _add_surface(ax, triangles[front], _shade(grey, normals[front], eye), seam_width=0.0)
        lines = Line3DCollection(MM_PER_M * pieces, colors=colours, linewidths=2.5, zorder=2)
        ax.add_collection3d(lines)
    _error_colour_bar(figure, axes, scale, "distance to reconstruction (mm)")
    lengths = np.linalg.norm(pieces[:, 1] - pieces[:, 0], axis=1)
    mean_mm = MM_PER_M * float(np.sum(lengths * piece_errors) / np.sum(lengths))
    figure.suptitle(f"Ground-truth sharp edges coloured by distance to the reconstruction (grey): "
                    f"length-weighted mean {mean_mm:.2f} mm, max {MM_PER_M * piece_errors.max():.2f} mm",
                    fontsize=11)
    return figure


def edge_error_view(truth, reconstruction, path, edges_m=None,
                    views: Sequence[Sequence[float]] = DEFAULT_VIEWS,
                    max_error_m: float | None = None, min_angle_rad: float = SHARP_ANGLE_RAD,
                    max_faces: int = 3000):
    """Write the truth's sharp edges coloured by their distance to the reconstruction.

    Edges are cut into pieces of at most 1 mm; each piece is coloured by the distance from its
    midpoint to the closest point of ``reconstruction`` (green 0 -> red ``max_error_m``), drawn over
    the reconstruction in translucent grey.

    Parameters
    ----------
    truth : trimesh.Trimesh
        Ground truth, object frame, metres.
    reconstruction : trimesh.Trimesh
        Reconstructed surface, same frame, metres.
    path : str or Path
        PNG file to write.
    edges_m : (k, 2, 3) float, optional
        Sharp edges of the truth, metres (e.g. ``objects.load(name).sharp_edges``); computed from
        ``truth`` with :func:`objects.features.sharp_edges` when omitted.
    views, max_error_m, max_faces
        As in :func:`error_coloured_views`.
    min_angle_rad : float
        Angle between neighbouring face normals above which an edge of ``truth`` is sharp,
        radians (used without ``edges_m``; default 30 deg).

    Returns
    -------
    Path of the PNG written.
    """
    check_png_path(path)
    return save_png(edge_error_view_figure(truth, reconstruction, edges_m, views, max_error_m,
                                           min_angle_rad, max_faces), path)


def edge_piece_errors(edges_m, reconstruction, piece_m: float = EDGE_PIECE_M
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Cut edges into pieces and measure each piece's distance to the reconstruction.

    Parameters
    ----------
    edges_m : (k, 2, 3) float, metres
    reconstruction : trimesh.Trimesh, same frame, metres
    piece_m : float
        Longest piece, metres.

    Returns
    -------
    pieces : (k', 2, 3) float, metres
    distances : (k',) float, from each piece's midpoint to the closest point of the
        reconstruction, metres
    """
    pieces = split_segments(finite_array(edges_m, "edges_m", (None, 2, 3)), piece_m)
    return pieces, distances_to_surface(pieces.mean(1), reconstruction)


def split_segments(segments: np.ndarray, max_length_m: float) -> np.ndarray:
    """Cut each (k, 2, 3) segment into equal pieces no longer than ``max_length_m``; (k', 2, 3)."""
    if not max_length_m > 0:
        raise ValueError(f"max_length_m must be > 0 m, got {max_length_m}")
    lengths = np.linalg.norm(segments[:, 1] - segments[:, 0], axis=1)
    counts = np.maximum(1, np.ceil(lengths / max_length_m).astype(int))
    owner = np.repeat(np.arange(len(segments)), counts)
    index = np.arange(len(owner)) - np.repeat(np.cumsum(counts) - counts, counts)
    start, step = segments[owner, 0], (segments[owner, 1] - segments[owner, 0]) / counts[owner, None]
    return np.stack([start + index[:, None] * step, start + (index[:, None] + 1) * step], axis=1)


# ---------------------------------------------------------------------- drawing helpers
def _view_grid(views, limits):
    from matplotlib.ticker import MaxNLocator

    figure = new_figure(3.8 * len(views) + 1.2, 4.8)
    axes = []
    for i, (elevation, azimuth) in enumerate(views):
        ax = figure.add_subplot(1, len(views), i + 1, projection="3d")
        ax.view_init(elev=elevation, azim=azimuth)
        ax.computed_zorder = False
        for setter, axis_limits in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), limits):
            setter(*(MM_PER_M * axis_limits))
        for set_label, label in zip((ax.set_xlabel, ax.set_ylabel, ax.set_zlabel), "xyz"):
            set_label(f"{label} (mm)", fontsize=8, labelpad=-2)
        ax.tick_params(labelsize=7, pad=-1)
        for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
            axis.set_major_locator(MaxNLocator(4))
        ax.set_box_aspect(tuple(limits[:, 1] - limits[:, 0]), zoom=0.95)
        # Seen from below, matplotlib draws the x/y tick labels on top: put the title underneath.
        ax.set_title(f"elevation {elevation:g}°, azimuth {azimuth:g}°", fontsize=9,
                     **(dict(pad=22) if elevation >= 0 else dict(y=-0.1)))
        axes.append(ax)
    figure.subplots_adjust(left=0.03, right=0.88, bottom=0.02, top=0.84, wspace=0.12)
    return figure, axes


def _add_surface(ax, triangles: np.ndarray, colours: np.ndarray, seam_width: float = 0.2) -> None:
    """Faces in their colours; a thin edge of the same colour hides seams between opaque faces."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    surface = Poly3DCollection(MM_PER_M * triangles, facecolors=colours, edgecolors=colours,
                               linewidths=seam_width, zorder=1)
    ax.add_collection3d(surface)


def _error_colour_bar(figure, axes, scale_m: float, label: str) -> None:
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    mappable = ScalarMappable(Normalize(0.0, MM_PER_M * scale_m), error_colour_map())
    bar_axes = figure.add_axes((0.915, 0.15, 0.015, 0.6))
    bar = figure.colorbar(mappable, cax=bar_axes)
    bar.set_label(label, fontsize=9)
    bar.ax.tick_params(labelsize=8)


def _shade(colours: np.ndarray, normals: np.ndarray, eye: np.ndarray) -> np.ndarray:
    """Scale RGB by a Lambert term lit from the camera and above (alpha kept)."""
    light = eye + np.array([0.0, 0.0, 0.5])
    light /= np.linalg.norm(light)
    low, high = SHADING
    brightness = low + (high - low) * np.clip(normals @ light, 0.0, 1.0)
    shaded = colours.copy()
    shaded[:, :3] *= brightness[:, None]
    return shaded


def _unit_normals(triangles: np.ndarray) -> np.ndarray:
    cross = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    return cross / np.maximum(np.linalg.norm(cross, axis=1, keepdims=True), 1e-30)


def _triangle_areas(triangles: np.ndarray) -> np.ndarray:
    return 0.5 * np.linalg.norm(np.cross(triangles[:, 1] - triangles[:, 0],
                                         triangles[:, 2] - triangles[:, 0]), axis=1)


def _normals_under(points: np.ndarray, triangles: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """(n, 3) normal of the face closest to each point (zeros for no points)."""
    if len(points) == 0:
        return np.zeros((0, 3))
    import trimesh

    mesh = trimesh.Trimesh(triangles.reshape(-1, 3), np.arange(3 * len(triangles)).reshape(-1, 3),
                           process=False)
    return normals[MeshProximity(mesh).query(points)[2]]


def _axis_limits(points: np.ndarray) -> np.ndarray:
    """(3, 2) lower and upper limit per axis around all points, metres.

    Each axis spans its own extent plus 5 %, but at least a quarter of the longest extent, so
    flat objects keep a readable thickness; the plot box takes these proportions (equal scale).
    """
    lo, hi = points.min(0), points.max(0)
    longest = max(float(np.max(hi - lo)), 1e-6)
    half = 0.525 * np.maximum(hi - lo, 0.25 * longest)
    centre = 0.5 * (lo + hi)
    return np.column_stack([centre - half, centre + half])


def _check_mesh(mesh, name: str) -> None:
    faces = getattr(mesh, "faces", None)
    vertices = getattr(mesh, "vertices", None)
    if faces is None or vertices is None:
        raise ValueError(f"{name} must be a trimesh.Trimesh, got {type(mesh).__name__}")
    if len(faces) == 0:
        raise ValueError(f"{name} has no faces")


def _check_views(views) -> list[tuple[float, float]]:
    views = [tuple(float(a) for a in view) for view in views]
    if not views or any(len(view) != 2 or not np.all(np.isfinite(view)) for view in views):
        raise ValueError(f"views must be a non-empty sequence of (elevation_deg, azimuth_deg), got {views}")
    return views
