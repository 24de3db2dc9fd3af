"""Closing a surface trimesh cannot: a scan with holes, a model made of open or overlapping parts.

The closed surface is the zero level set of a signed distance to the file's triangles whose sign is
the generalized winding number (Jacobson, Kavan and Sorkine-Hornung 2013, "Robust inside-outside
segmentation using generalized winding numbers"; libigl's fast winding number): inside where the
triangles wind around a point more than half way, which stays defined across holes, overlaps and
non-manifold edges. It is sampled on a regular grid, meshed by marching cubes (scikit-image) and
decimated where that keeps it closed (fast-simplification's quadric decimation, a dependency of the
project: an import error here is a broken install, not an option).
Away from the holes the new surface follows the file's to a small fraction of the grid spacing
(the distance is exact; marching cubes interpolates it linearly); across a hole it spans the
opening; sharp edges are rounded by about half the spacing.

Written here rather than taken from a mesh-repair library: MeshFix (pymeshfix) is AGPL, and this is
two calls into libigl and scikit-image, which the project already uses.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

#: Grid spacing as a fraction of the mesh's largest side, and its bounds, metres: ~150 cells across,
#: ~1 mm on a 15 cm object (100-200 k faces).
SPACING_FRACTION = 1.0 / 150.0
SPACING_BOUNDS_M = (0.0005, 0.005)
#: A piece of the closed surface with less than this fraction of the largest piece's area is a speck of
#: the level set (a grid cell where the winding number hovers at one half), dropped.
SPECK_AREA_FRACTION = 1e-3
#: Face counts a closed surface is decimated to, fewest first, and the decimator's aggressions tried
#: at each (lower keeps it closer to the level set; the first that stays closed within half a cell
#: is taken). 20,000 is about the largest generated object's.
DECIMATED_FACES = (20000, 40000, 80000)
DECIMATION_AGGRESSIONS = (3, 2, 4, 5)
#: The grid's offset from the mesh's bounds, in cells (1 / pi: never a round fraction).
GRID_SHIFT = 1.0 / np.pi
#: Bumped when a change here changes the closed surface (meshes closed before are then closed again).
CLOSING_VERSION = 2


@dataclass(frozen=True)
class ClosedSurface:
    """A closed surface made from an open one.

    Attributes
    ----------
    mesh : trimesh.Trimesh
        Watertight, outward normals, the input's frame and units.
    spacing_m : float
        Grid spacing of the winding-number field.
    spanned_fraction : float
        Share of the closed surface's area farther than ``spacing_m`` from every input triangle:
        what was made up to span holes (0.01 for a scan with a few small holes, 0.33 for a
        hemispherical shell closed by its disc).
    specks_dropped : int
        Tiny pieces of the level set removed (:data:`SPECK_AREA_FRACTION`).
    level_set_faces : int
        Faces marching cubes made; ``mesh`` has fewer when it could be decimated (:func:`_decimated`).
    """

    mesh: trimesh.Trimesh
    spacing_m: float
    spanned_fraction: float
    specks_dropped: int
    level_set_faces: int


def _outward_parts(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """``mesh`` with each connected part wound consistently and outward: its signed volume about its
    own centroid positive, which holds for an open part too (a part wound inside out would cancel the
    winding number of the parts it overlaps). A closed inner shell meant as a cavity is turned
    outward as well, so it is filled."""
    merged = mesh.copy()
    merged.merge_vertices()
    # Parts by shared vertices, not shared edges: a mesh of quads joined only at their corners is
    # one part, not a thousand two-triangle patches each turned its own way.
    labels = trimesh.graph.connected_component_labels(merged.edges_unique, node_count=len(merged.vertices))
    face_labels = labels[merged.faces[:, 0]]
    parts = [merged.submesh([np.flatnonzero(face_labels == label)], append=True) for label in np.unique(face_labels)]
    for part in parts:
        if not part.is_winding_consistent:  # trimesh's fix can flip patches of a consistent open part
            trimesh.repair.fix_winding(part)
        corners = part.triangles - part.triangles.reshape(-1, 3).mean(axis=0)
        signed_volume = np.einsum("ij,ij->i", corners[:, 0], np.cross(corners[:, 1], corners[:, 2])).sum()
        if signed_volume < 0:
            part.invert()
    return trimesh.util.concatenate(parts) if len(parts) > 1 else parts[0]


def grid_spacing(mesh: trimesh.Trimesh) -> float:
    """The grid spacing :func:`close_surface` uses for ``mesh``, metres."""
    low, high = SPACING_BOUNDS_M
    return float(np.clip(np.max(mesh.extents) * SPACING_FRACTION, low, high))


def close_surface(mesh: trimesh.Trimesh, spacing_m: float | None = None) -> ClosedSurface:
    """The closed surface enclosing what ``mesh`` winds around (see the module docstring).

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Any triangles: open, several parts, overlapping, inconsistently wound (each connected part
        is wound outward first). Not modified.
    spacing_m : float, optional
        Grid spacing, metres; default :func:`grid_spacing`.

    Raises
    ------
    ValueError
        When the triangles enclose no volume (a flat sheet, a single open patch) or the level set
        does not come out closed.
    """
    import igl  # noqa: PLC0415 - libigl and scikit-image load only when a mesh needs closing
    from skimage import measure  # noqa: PLC0415

    spacing = grid_spacing(mesh) if spacing_m is None else float(spacing_m)
    oriented = _outward_parts(mesh)
    vertices = np.ascontiguousarray(oriented.vertices, dtype=np.float64)
    faces = np.ascontiguousarray(oriented.faces, dtype=np.int64)

    # Off the file's round coordinates by an irrational fraction of a cell, so that no grid point
    # lies on a face a modeller put on a round coordinate (a CAD part's flat sides).
    lower = oriented.bounds[0] - (3 + GRID_SHIFT) * spacing
    counts = np.ceil((oriented.bounds[1] + 3 * spacing - lower) / spacing).astype(int) + 1
    axes = [lower[i] + spacing * np.arange(counts[i]) for i in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    signed, _, _, _ = igl.signed_distance(grid, vertices, faces,
                                          sign_type=igl.SIGNED_DISTANCE_TYPE_FAST_WINDING_NUMBER)
    # A grid point exactly on the surface makes marching cubes pinch it there: count it as outside.
    field = np.where(signed == 0.0, 1e-9 * spacing, signed).reshape(counts)
    if not (field.min() < 0 < field.max()):
        raise ValueError("the triangles enclose no volume")
    level_vertices, level_faces, _, _ = measure.marching_cubes(field, 0.0, spacing=(spacing,) * 3)
    # As marching cubes made it: its vertices are shared already, and merging the near-coincident
    # ones it makes where the level set grazes a grid point would pinch the surface open.
    closed = trimesh.Trimesh(level_vertices + lower, level_faces, process=False)

    pieces = closed.split(only_watertight=False)
    areas = np.array([piece.area for piece in pieces])
    kept = [piece for piece, area in zip(pieces, areas) if area > SPECK_AREA_FRACTION * areas.max()]
    closed = trimesh.util.concatenate(kept) if len(kept) > 1 else kept[0]
    if not closed.is_watertight:
        raise ValueError("the winding-number surface did not come out closed")
    if closed.volume < 0:
        closed.invert()
    squared, _, _ = igl.point_mesh_squared_distance(np.ascontiguousarray(closed.triangles_center), vertices, faces)
    spanned = closed.area_faces[np.sqrt(squared) > spacing].sum() / closed.area
    level_set_faces = len(closed.faces)
    closed = _decimated(closed, spacing / 2)
    return ClosedSurface(mesh=closed, spacing_m=spacing, spanned_fraction=float(spanned),
                         specks_dropped=len(pieces) - len(kept), level_set_faces=level_set_faces)


def _decimated(closed: trimesh.Trimesh, tolerance_m: float) -> trimesh.Trimesh:
    """``closed`` decimated to the fewest of :data:`DECIMATED_FACES` faces (quadric decimation,
    fast-simplification) at which one of the tries stays closed, in as many pieces, with every vertex
    within ``tolerance_m`` of ``closed``; else ``closed`` as it is. Marching cubes spends a face per half cell even on flat
    parts, and the simulator pays for the faces (the closed bunny: 2.1x slower on 154 k than on 20 k)."""
    import igl  # noqa: PLC0415

    vertices = np.ascontiguousarray(closed.vertices, dtype=np.float64)
    faces = np.ascontiguousarray(closed.faces, dtype=np.int64)
    for face_count in (count for count in DECIMATED_FACES if count < len(closed.faces)):
        for aggression in DECIMATION_AGGRESSIONS:
            smaller = closed.simplify_quadric_decimation(face_count=face_count, aggression=aggression)
            if not (smaller.is_watertight and smaller.body_count == closed.body_count and smaller.volume > 0):
                continue
            squared, _, _ = igl.point_mesh_squared_distance(np.ascontiguousarray(smaller.vertices), vertices, faces)
            if np.sqrt(squared.max()) <= tolerance_m:
                return smaller
    return closed
