"""Load a ground-truth object by registry name or from a user mesh file (OBJ, STL, PLY).

A user mesh is checked (readable, non-empty, finite, plausible size in metres, watertight with
outward normals), repaired where trimesh can do it (with a warning that says what changed) and
written with a URDF into a cache folder so PyBullet can load it.
"""
from __future__ import annotations

import hashlib
import os
import pathlib
import warnings

import numpy as np
import trimesh

from objects.catalogue import DATA_DIR, SPECS, mesh_filename, names, spec, urdf_filename
from objects.features import sharp_edges
from objects.files import obj_text, urdf_text
from objects.model import ObjectModel

MESH_SUFFIXES = (".obj", ".stl", ".ply")
PLAUSIBLE_EXTENT_M = (0.005, 2.0)
MERGE_TOLERANCE_M = 1e-6
USER_RGBA = (0.75, 0.75, 0.75, 1.0)


def default_cache_dir() -> pathlib.Path:
    """Where URDFs for user meshes go: $XDG_CACHE_HOME (or ~/.cache) / tactile_explore / objects."""
    base = os.environ.get("XDG_CACHE_HOME") or pathlib.Path.home() / ".cache"
    return pathlib.Path(base) / "tactile_explore" / "objects"


def load(name_or_path: str | os.PathLike, *, scale: float | None = None,
         cache_dir: str | os.PathLike | None = None) -> ObjectModel:
    """The object called ``name_or_path`` in the registry, or the mesh in that file.

    Parameters
    ----------
    name_or_path : str or path-like
        A name from :func:`objects.names`, or a path to an .obj, .stl or .ply file.
    scale : float, optional
        Factor applied to a mesh file's coordinates to get metres (0.001 for a file in
        millimetres). Not allowed with a registry name.
    cache_dir : path-like, optional
        Folder for the URDF (and cleaned OBJ) of a mesh file; default :func:`default_cache_dir`.
        The sub-folder is named after the file's content and ``scale``, so it is deterministic.

    Returns
    -------
    ObjectModel
        A fresh mesh each call.

    Raises
    ------
    ValueError
        Unknown name (the message lists the valid ones), unsupported suffix, unreadable or empty
        file, implausible size, or a mesh that is not watertight after repair.
    FileNotFoundError
        A path that does not exist.
    """
    if isinstance(name_or_path, str) and name_or_path in SPECS:
        if scale is not None:
            raise ValueError("scale applies to mesh files only, not to registry objects")
        return _load_registry(name_or_path)
    path = pathlib.Path(name_or_path)
    if path.suffix.lower() not in MESH_SUFFIXES:
        if isinstance(name_or_path, str) and os.sep not in name_or_path and not path.suffix:
            spec(name_or_path)  # raises with the list of valid names
        raise ValueError(f"{path}: unsupported mesh file type {path.suffix!r}; use one of "
                         f"{', '.join(MESH_SUFFIXES)} or a registry name ({', '.join(names())})")
    if not path.is_file():
        raise FileNotFoundError(f"mesh file {path} does not exist")
    return _load_file(path, 1.0 if scale is None else scale,
                      pathlib.Path(cache_dir) if cache_dir is not None else default_cache_dir())


def _model(name: str, description: str, mesh: trimesh.Trimesh, mesh_path: pathlib.Path,
           urdf_path: pathlib.Path) -> ObjectModel:
    lower, upper = np.asarray(mesh.bounds, float)
    return ObjectModel(name=name, description=description, mesh=mesh, mesh_path=mesh_path,
                       urdf_path=urdf_path, sharp_edges=sharp_edges(mesh),
                       centre_m=(lower + upper) / 2, extent_m=upper - lower)


def _load_registry(name: str) -> ObjectModel:
    mesh_path, urdf_path = DATA_DIR / mesh_filename(name), DATA_DIR / urdf_filename(name)
    mesh = trimesh.load(mesh_path, file_type="obj", force="mesh", process=False)
    if not (mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0):
        raise ValueError(f"{mesh_path}: committed mesh is not a closed outward-facing surface; "
                         "regenerate it with `python -m objects.generate`")
    return _model(name, spec(name).description, mesh, mesh_path, urdf_path)


def _read_mesh(path: pathlib.Path) -> trimesh.Trimesh:
    """Triangles from ``path``, exactly coincident vertices merged (STL stores every corner apart)."""
    try:
        loaded = trimesh.load(path, file_type=path.suffix.lower().lstrip("."), force="mesh", process=True)
    except Exception as error:  # trimesh raises many types for a malformed file
        raise ValueError(f"{path}: could not read as a mesh ({type(error).__name__}: {error})") from error
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise ValueError(f"{path}: the file contains no triangles (empty mesh)")
    if not np.all(np.isfinite(loaded.vertices)):
        raise ValueError(f"{path}: the mesh has non-finite vertex coordinates")
    return loaded


def _check_size(path: pathlib.Path, mesh: trimesh.Trimesh, scale: float) -> None:
    """ValueError unless the largest side of the bounding box is a plausible object size in metres."""
    largest = float(np.max(mesh.extents))
    low, high = PLAUSIBLE_EXTENT_M
    if low <= largest <= high:
        return
    hint = ""
    for factor, unit in ((0.001, "millimetres"), (0.01, "centimetres"), (0.0254, "inches")):
        if low <= largest * factor <= high and largest > high:
            hint = f"; if the file is in {unit}, pass scale={scale * factor:g}"
            break
    raise ValueError(f"{path}: largest extent {largest:g} m (after scale={scale:g}) is outside the "
                     f"plausible range {low:g}..{high:g} m for an object; coordinates must be metres{hint}")


def _repair(path: pathlib.Path, mesh: trimesh.Trimesh) -> list[str]:
    """Make ``mesh`` watertight with outward normals in place; return what was changed.

    Raises ValueError naming the file when the mesh stays open or non-manifold.
    """
    repairs = []
    n_vertices = len(mesh.vertices)
    mesh.merge_vertices(digits_vertex=int(-np.log10(MERGE_TOLERANCE_M)))
    if len(mesh.vertices) < n_vertices:
        repairs.append(f"merged {n_vertices - len(mesh.vertices)} vertices closer than "
                       f"{MERGE_TOLERANCE_M * 1e3:g} mm")
    n_faces = len(mesh.faces)
    mesh.update_faces(mesh.nondegenerate_faces())
    mesh.update_faces(mesh.unique_faces())
    mesh.remove_unreferenced_vertices()
    if len(mesh.faces) < n_faces:
        repairs.append(f"removed {n_faces - len(mesh.faces)} degenerate or duplicate faces")
    if not mesh.is_watertight:
        n_faces = len(mesh.faces)
        trimesh.repair.fill_holes(mesh)
        if len(mesh.faces) > n_faces:
            repairs.append(f"filled holes with {len(mesh.faces) - n_faces} faces")
    if not mesh.is_watertight:
        edges = mesh.edges_sorted
        _, counts = np.unique(edges, axis=0, return_counts=True)
        raise ValueError(f"{path}: mesh is not watertight even after repair "
                         f"({int(np.sum(counts == 1))} open edges, {int(np.sum(counts > 2))} edges shared "
                         "by more than two faces); close the surface in a mesh editor")
    if not mesh.is_winding_consistent:
        trimesh.repair.fix_winding(mesh)
        repairs.append("made face winding consistent")
        if not mesh.is_winding_consistent:
            raise ValueError(f"{path}: face winding cannot be made consistent (non-orientable surface?)")
    if mesh.volume < 0:
        mesh.invert()
        repairs.append("inverted faces so normals point outward")
    return repairs


def _cache_folder(path: pathlib.Path, scale: float, cache_dir: pathlib.Path) -> pathlib.Path:
    digest = hashlib.sha256(path.read_bytes() + f"|scale={scale!r}".encode()).hexdigest()[:16]
    return cache_dir / f"{path.stem}-{digest}"


def _write_if_changed(target: pathlib.Path, text: str) -> None:
    """Write atomically, skipping identical content (several processes may share the cache)."""
    if target.is_file() and target.read_text() == text:
        return
    temporary = target.with_name(f".{target.name}.{os.getpid()}.tmp")
    temporary.write_text(text)
    os.replace(temporary, target)


def _load_file(path: pathlib.Path, scale: float, cache_dir: pathlib.Path) -> ObjectModel:
    if not (np.isfinite(scale) and scale > 0):
        raise ValueError(f"scale must be a positive finite number, got {scale}")
    mesh = _read_mesh(path)
    if scale != 1.0:
        mesh.apply_scale(scale)
    _check_size(path, mesh, scale)
    repairs = _repair(path, mesh)
    if repairs:
        warnings.warn(f"{path}: repaired mesh: {'; '.join(repairs)}", stacklevel=3)

    name = path.stem
    folder = _cache_folder(path, scale, cache_dir)
    folder.mkdir(parents=True, exist_ok=True)
    mesh_path, urdf_path = folder / f"{name}.obj", folder / f"{name}.urdf"
    _write_if_changed(mesh_path, obj_text(mesh, f"{name}: from {path} (scale {scale:g}), checked by objects.load"))
    _write_if_changed(urdf_path, urdf_text(name, mesh_path.name, USER_RGBA))
    description = f"user mesh {path.name} (scale {scale:g}), {' x '.join(f'{e * 1e3:.1f}' for e in mesh.extents)} mm"
    return _model(name, description, mesh, mesh_path, urdf_path)
