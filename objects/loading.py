"""Load a ground-truth object by registry name, generated name or from a user mesh file (OBJ, STL, PLY,
OFF, GLB).

A user mesh is checked (readable, non-empty, finite, plausible size in metres, watertight with
outward normals), repaired where trimesh can do it (with a warning that says what changed), its
overlapping or touching parts merged into their outer surface (boolean union, with a warning); a
surface that stays open (a scan with holes, open parts) is closed by its winding number
(:mod:`objects.closing`, with a warning that says how much of it spans holes; refused when that is
more than :data:`MAX_SPANNED_FRACTION`, an open shell rather than a solid), and its origin moved to
the centre of its bounding box (with a warning) when it lies elsewhere, as it does for every registry
and generated object. The result is written with a URDF into a cache folder so PyBullet can load it. A generated object
(``generated:mug/3``, :mod:`objects.generated`) is rebuilt from its name and written to the same cache.
"""
from __future__ import annotations

import hashlib
import json
import os
import pathlib
import warnings

import numpy as np
import trimesh

from objects.catalogue import DATA_DIR, SPECS, mesh_filename, names, spec, urdf_filename
from objects.closing import CLOSING_VERSION, close_surface
from objects.features import sharp_edges
from objects.files import obj_text, urdf_text
from objects.generated import building as generated
from objects.model import ObjectModel

MESH_SUFFIXES = (".obj", ".stl", ".ply", ".off", ".glb")
#: Largest side of a user mesh's bounding box that is accepted as a hand-held object, metres.
PLAUSIBLE_EXTENT_M = (0.01, 1.0)
#: Length units a mesh file may be in: the command-line flag ``--units`` and its factor to metres.
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254}
UNIT_NAMES = {"m": "metres", "cm": "centimetres", "mm": "millimetres", "in": "inches"}
#: A typical hand-held object's largest side, metres: unit guesses aim at it.
TYPICAL_EXTENT_M = 0.1
MERGE_TOLERANCE_M = 1e-6
#: An open surface closed by its winding number is refused when more of the closed surface than this
#: spans openings: it was a shell (a bowl modelled without thickness), not a solid with holes.
MAX_SPANNED_FRACTION = 0.1
USER_RGBA = (0.75, 0.75, 0.75, 1.0)
#: A user mesh whose bounding-box centre lies farther than this from its origin is moved to put it there.
CENTRING_TOLERANCE_M = 0.001
#: Beside a closed mesh in the cache: what closing it did (read back instead of closing it again).
CLOSED_NOTE = "closed.json"
CLOSED_SUFFIX = ".closed.obj"


def default_cache_dir() -> pathlib.Path:
    """Where URDFs for user meshes go: $XDG_CACHE_HOME (or ~/.cache) / tactile_explore / objects."""
    base = os.environ.get("XDG_CACHE_HOME") or pathlib.Path.home() / ".cache"
    return pathlib.Path(base) / "tactile_explore" / "objects"


def units_scale(units: str) -> float:
    """Factor from ``units`` (a key of :data:`UNITS`: m, cm, mm, in) to metres; ValueError otherwise."""
    if units not in UNITS:
        raise ValueError(f"unknown length unit {units!r}; choose from {', '.join(UNITS)}")
    return UNITS[units]


def is_mesh_file_name(name_or_path) -> bool:
    """Whether ``name_or_path`` names a mesh file (by suffix) rather than a registry or generated object."""
    return (not generated.is_generated_name(name_or_path)
            and pathlib.Path(name_or_path).suffix.lower() in MESH_SUFFIXES)


def file_label(name_or_path: str | os.PathLike) -> str:
    """A short name usable in file names: a registry name as is, ``generated:mug/3`` ->
    ``generated-mug-3``, a mesh file by its stem."""
    if generated.is_generated_name(name_or_path):
        family, seed = generated.parse_name(name_or_path)
        return f"generated-{family}-{seed}"
    path = pathlib.Path(name_or_path)
    return path.stem if path.suffix else str(name_or_path)


def in_metres(name_or_path: str | os.PathLike, units: str = "m", *,
              cache_dir: str | os.PathLike | None = None) -> str:
    """The name to pass on for ``name_or_path`` whose mesh file is in ``units``.

    Registry and generated names come back unchanged, a mesh file in metres as its absolute path
    (so a session recorded with it names a file a replay from another directory finds; a mesh
    file and a generated name are checked: the errors of :func:`load`). A mesh file in
    other units is loaded (checked, repaired) with that scale, and the path of its cleaned copy in
    metres (in the cache) is returned, so code that only takes a name (the simulation, a sweep
    worker, a resumed run) loads the right size. The command-line ``--units`` flag uses this.
    """
    factor = units_scale(units)
    if is_mesh_file_name(name_or_path):
        # Checked now, not mid-run. The copy in metres keeps the file's frame: each later load of it
        # centres it again, so its runs record the same shift as the file's (ObjectModel.file_shift_m).
        model = load(name_or_path, scale=factor, cache_dir=cache_dir, keep_frame=factor != 1.0)
        return os.path.abspath(name_or_path) if factor == 1.0 else str(model.mesh_path)
    if factor != 1.0:
        raise ValueError(f"--units {units} applies to mesh files only, not to {str(name_or_path)!r}")
    if generated.is_generated_name(name_or_path):
        generated.parse_name(name_or_path)
    return str(name_or_path)


#: The key under which a run records :attr:`ObjectModel.file_shift_m` (millimetres) in its session
#: metadata and ``metrics.json``, when its mesh was moved.
FILE_SHIFT_KEY = "object_file_shift_mm"


def shift_record(model: ObjectModel) -> dict:
    """``{FILE_SHIFT_KEY: [x, y, z] mm}`` for a model whose origin was moved, else ``{}``: what a run records."""
    return {FILE_SHIFT_KEY: (1e3 * model.file_shift_m).tolist()} if np.any(model.file_shift_m) else {}


def load_as_recorded(name: str, record: dict) -> ObjectModel:
    """The object a run's record (its session metadata or ``metrics.json``) names, in the frame the
    run explored it in: centred when it recorded a shift (:func:`shift_record`), the file's own
    otherwise (no shift, or recorded before user meshes were centred, 2026-11-28)."""
    return load(name, keep_frame=FILE_SHIFT_KEY not in record)


def load(name_or_path: str | os.PathLike, *, scale: float | None = None,
         cache_dir: str | os.PathLike | None = None, keep_frame: bool = False) -> ObjectModel:
    """The object called ``name_or_path`` in the registry, a generated object, or the mesh in a file.

    Parameters
    ----------
    name_or_path : str or path-like
        A name from :func:`objects.names`, a generated name ``generated:<family>/<seed>`` (see
        :mod:`objects.generated`), or a path to an .obj, .stl or .ply file.
    scale : float, optional
        Factor applied to a mesh file's coordinates to get metres (0.001 for a file in
        millimetres; ``--units mm`` on the command line). Not allowed with a registry or generated name.
    cache_dir : path-like, optional
        Folder for the URDF (and cleaned OBJ) of a mesh file or generated object; default
        :func:`default_cache_dir`. The sub-folder is named after the file's content and ``scale``
        (or the generated name), so it is deterministic.
    keep_frame : bool
        Keep a mesh file's own frame even when its bounding-box centre is far from its origin: a
        reference mesh registered to a real object's frame. False (an object to simulate): moved
        to that centre, with a warning (:func:`_centred`).

    Returns
    -------
    ObjectModel
        A fresh mesh each call.

    Raises
    ------
    ValueError
        Unknown name (the message lists the valid ones), malformed generated name or unknown family
        (listed), unsupported suffix, unreadable or empty file, implausible size (the message names
        the likely unit and the ``--units`` flag), or an open surface that cannot be closed or is a
        shell (:func:`_closed`).
    FileNotFoundError
        A path that does not exist.
    """
    if isinstance(name_or_path, str) and name_or_path in SPECS:
        if scale is not None:
            raise ValueError("scale applies to mesh files only, not to registry objects")
        return _load_registry(name_or_path)
    if generated.is_generated_name(name_or_path):
        if scale is not None:
            raise ValueError("scale applies to mesh files only, not to generated objects")
        return _load_generated(name_or_path, pathlib.Path(cache_dir) if cache_dir is not None else default_cache_dir())
    path = pathlib.Path(name_or_path)
    if path.suffix.lower() not in MESH_SUFFIXES:
        if isinstance(name_or_path, str) and os.sep not in name_or_path and not path.suffix:
            spec(name_or_path)  # raises with the list of valid names
        raise ValueError(f"{path}: unsupported mesh file type {path.suffix!r}; use one of "
                         f"{', '.join(MESH_SUFFIXES)} or a registry name ({', '.join(names())})")
    if not path.is_file():
        raise FileNotFoundError(f"mesh file {path} does not exist")
    return _load_file(path, 1.0 if scale is None else scale,
                      pathlib.Path(cache_dir) if cache_dir is not None else default_cache_dir(), keep_frame)


def _model(name: str, description: str, mesh: trimesh.Trimesh, mesh_path: pathlib.Path,
           urdf_path: pathlib.Path, file_shift_m=(0.0, 0.0, 0.0)) -> ObjectModel:
    lower, upper = np.asarray(mesh.bounds, float)
    return ObjectModel(name=name, description=description, mesh=mesh, mesh_path=mesh_path,
                       urdf_path=urdf_path, sharp_edges=sharp_edges(mesh),
                       centre_m=(lower + upper) / 2, extent_m=upper - lower,
                       file_shift_m=np.asarray(file_shift_m, float))


def _load_registry(name: str) -> ObjectModel:
    mesh_path, urdf_path = DATA_DIR / mesh_filename(name), DATA_DIR / urdf_filename(name)
    mesh = trimesh.load(mesh_path, file_type="obj", force="mesh", process=False)
    if not (mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0):
        raise ValueError(f"{mesh_path}: committed mesh is not a closed outward-facing surface; "
                         "regenerate it with `python -m objects.generate`")
    return _model(name, spec(name).description, mesh, mesh_path, urdf_path)


def _load_generated(name: str, cache_dir: pathlib.Path) -> ObjectModel:
    family, seed = generated.parse_name(name)
    mesh = generated.build_mesh(family, seed)
    folder = generated.cache_folder(cache_dir, family, seed)
    folder.mkdir(parents=True, exist_ok=True)
    stem = f"{family}_{seed}"
    mesh_path, urdf_path = folder / f"{stem}.obj", folder / f"{stem}.urdf"
    _write_if_changed(mesh_path, obj_text(mesh, f"{name}: built by objects.generated "
                                                f"(generator version {generated.GENERATOR_VERSION})"))
    _write_if_changed(urdf_path, urdf_text(stem, mesh_path.name, generated.RGBA))
    return _model(name, generated.description(family, seed, mesh), mesh, mesh_path, urdf_path)


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
    """ValueError unless the largest side of the bounding box is a plausible hand-held size in metres.

    The message names the unit the file is most likely in (the one that brings the largest side
    nearest :data:`TYPICAL_EXTENT_M` within the accepted range) and the ``--units`` flag to say so.
    """
    largest = float(np.max(mesh.extents))
    low, high = PLAUSIBLE_EXTENT_M
    if low <= largest <= high:
        return
    raw = largest / scale  # in the file's own numbers
    fits = [unit for unit, factor in UNITS.items()
            if low <= raw * factor <= high and not np.isclose(factor, scale)]
    hint = "; coordinates must be metres, or give the file's unit with --units"
    if fits:
        unit = min(fits, key=lambda u: abs(np.log(raw * UNITS[u] / TYPICAL_EXTENT_M)))
        hint = (f"; the file is likely in {UNIT_NAMES[unit]}: pass --units {unit} "
                f"(scale={UNITS[unit]:g} from Python), which makes it {_mm(raw * UNITS[unit])} mm")
    raise ValueError(f"{path}: largest extent {_mm(largest)} mm (scale {scale:g}) is outside "
                     f"{low * 1e3:g} mm .. {high * 1e3:g} mm for a hand-held object{hint}")


def _mm(length_m: float) -> str:
    return f"{length_m * 1e3:.2f}" if length_m < 0.01 else f"{length_m * 1e3:.0f}"


class _OpenSurface(ValueError):
    """A surface trimesh's repairs leave open; the message says how."""


def _repair(path: pathlib.Path, mesh: trimesh.Trimesh, orient: bool = True) -> list[str]:
    """Make ``mesh`` watertight with consistent winding, and with outward normals unless ``orient``
    is False (a part that may be a cavity), in place; return what was changed.

    Raises _OpenSurface when the mesh stays open or non-manifold.
    """
    repairs = []
    n_vertices = len(mesh.vertices)
    mesh.merge_vertices(digits_vertex=int(-np.log10(MERGE_TOLERANCE_M)))
    if len(mesh.vertices) < n_vertices:
        repairs.append(f"merged {n_vertices - len(mesh.vertices)} vertices closer than "
                       f"{MERGE_TOLERANCE_M * 1e3:g} mm")
    keep = mesh.nondegenerate_faces() & mesh.unique_faces()
    # A zero-area face of a closed surface (marching cubes makes them where the level set grazes a
    # grid point) stays: dropping it opens a hole that filling closes with the same face.
    if not keep.all() and not (mesh.is_watertight and not mesh.submesh([keep], append=True).is_watertight):
        mesh.update_faces(keep)
        mesh.remove_unreferenced_vertices()
        repairs.append(f"removed {int(np.sum(~keep))} degenerate or duplicate faces")
    if not mesh.is_watertight:
        n_faces = len(mesh.faces)
        trimesh.repair.fill_holes(mesh)
        if len(mesh.faces) > n_faces:
            repairs.append(f"filled holes with {len(mesh.faces) - n_faces} faces")
    if not mesh.is_watertight:
        edges = mesh.edges_sorted
        _, counts = np.unique(edges, axis=0, return_counts=True)
        raise _OpenSurface(f"the surface is open even after repair ({int(np.sum(counts == 1))} open "
                           f"edges, {int(np.sum(counts > 2))} edges shared by more than two faces)")
    if not mesh.is_winding_consistent:
        trimesh.repair.fix_winding(mesh)
        repairs.append("made face winding consistent")
        if not mesh.is_winding_consistent:
            raise ValueError(f"{path}: face winding cannot be made consistent (non-orientable surface?)")
    if orient and mesh.volume < 0:
        mesh.invert()
        repairs.append("inverted faces so normals point outward")
    return repairs


def _remove_internal_face_pairs(mesh: trimesh.Trimesh) -> int:
    """Drop both faces of every pair on the same three vertices with opposite winding: the shared
    wall of two parts that touch along a face. Returns how many faces were removed."""
    faces = np.asarray(mesh.faces)
    _, inverse, counts = np.unique(np.sort(faces, axis=1), axis=0, return_inverse=True, return_counts=True)
    first = np.argmin(faces, axis=1)[:, None]
    rolled = np.take_along_axis(faces, (first + np.arange(3)) % 3, axis=1)  # same cycle, lowest index first
    _, same_inverse, same_counts = np.unique(rolled, axis=0, return_inverse=True, return_counts=True)
    paired = (counts[inverse.ravel()] == 2) & (same_counts[same_inverse.ravel()] == 1)
    if not np.any(paired):
        return 0
    mesh.update_faces(~paired)
    mesh.remove_unreferenced_vertices()
    return int(np.sum(paired))


def _parts_as_written(path: pathlib.Path, scale: float) -> list[trimesh.Trimesh] | None:
    """The closed parts of a file whose parts touch (an OBJ of several objects keeps each part's own
    vertices), or None when the file's own vertex sharing does not give two or more closed parts."""
    try:
        raw = trimesh.load(path, file_type=path.suffix.lower().lstrip("."), force="mesh", process=False)
    except Exception:  # noqa: BLE001 - read once already; any failure here means "no parts"
        return None
    parts = raw.split(only_watertight=False)
    for part in parts:
        part.apply_scale(scale)
        part.merge_vertices()
    if len(parts) < 2 or not all(part.is_watertight for part in parts):
        return None
    return list(parts)


def _merge_parts(path: pathlib.Path, parts: list[trimesh.Trimesh]) -> tuple[trimesh.Trimesh, list[str]]:
    """The outer surface of several closed parts (a convex decomposition, say).

    Parts with outward normals are united (manifold3d through trimesh); a part with inward normals
    inside the others is a cavity and is subtracted. Returns the mesh and what was done (nothing
    for one solid with cavities: that is a valid hollow object as it stands).
    """
    solids = [part for part in parts if part.volume > 0]
    inward = [part for part in parts if part.volume <= 0]
    outer = trimesh.boolean.union(solids, engine="manifold") if len(solids) > 1 else (solids or [None])[0]
    cavities = [part for part in inward if outer is not None and np.all(outer.contains(part.vertices))]
    flipped = [part for part in inward if not any(part is cavity for cavity in cavities)]
    for part in flipped:  # an inside-out part, not a cavity
        part.invert()
    united = solids + flipped
    if flipped:
        outer = trimesh.boolean.union(united, engine="manifold") if len(united) > 1 else united[0]
    if cavities:
        for cavity in cavities:
            cavity.invert()
        outer = trimesh.boolean.difference([outer, *cavities], engine="manifold")
    if not (outer.is_watertight and outer.volume > 0):
        raise _OpenSurface(f"the union of its {len(parts)} parts is not a closed surface")
    if len(united) < 2:
        return outer, [f"turned {len(flipped)} inside-out part outward"] if flipped else []
    pieces = sum(1 for body in outer.split(only_watertight=False) if body.volume > 0)
    details = ((f", {len(flipped)} of them turned outward first" if flipped else "")
               + (f", {len(cavities)} inner shells kept as cavities" if cavities else ""))
    if pieces >= len(united):
        what = (f"its {len(united)} parts do not touch one another{details}; they are explored and "
                f"scored as one object of {pieces} separate pieces (remove the others in a mesh editor "
                "if only one is the object)")
    else:
        what = (f"merged {len(united)} overlapping or touching parts into their outer surface (boolean union)"
                + details + (f"; {pieces} separate pieces remain (they do not touch)" if pieces > 1 else ""))
    return outer, [what]


def _cache_folder(path: pathlib.Path, scale: float, cache_dir: pathlib.Path, keep_frame: bool) -> pathlib.Path:
    key = f"|scale={scale!r}" + ("|file frame" if keep_frame else "")
    digest = hashlib.sha256(path.read_bytes() + key.encode()).hexdigest()[:16]
    return cache_dir / f"{path.stem}-{digest}"


def _write_if_changed(target: pathlib.Path, text: str) -> None:
    """Write atomically, skipping identical content (several processes may share the cache)."""
    if target.is_file() and target.read_text() == text:
        return
    temporary = target.with_name(f".{target.name}.{os.getpid()}.tmp")
    temporary.write_text(text)
    os.replace(temporary, target)


def _repaired(path: pathlib.Path, mesh: trimesh.Trimesh, scale: float) -> tuple[trimesh.Trimesh, list[str]]:
    """``mesh`` (a copy) made watertight by trimesh's repairs and the union of its parts, and what
    was done; raises _OpenSurface when that does not close it."""
    mesh = mesh.copy()
    removed = _remove_internal_face_pairs(mesh)
    repairs = [f"removed {removed} coincident faces where parts touch"] if removed else []
    # Parts meet at edges shared by more than two faces; split there (trimesh's face adjacency
    # skips such edges), repair each part, then unite them.
    parts = mesh.split(only_watertight=False)
    if len(parts) > 1 and not all(part.is_watertight for part in parts):
        parts = _parts_as_written(path, scale) or parts
    if len(parts) < 2:
        repairs += _repair(path, mesh)
    else:
        for part in parts:
            repairs += _repair(path, part, orient=False)
        mesh, merged = _merge_parts(path, parts)
        repairs += merged
    return mesh, repairs


def _closed(path: pathlib.Path, mesh: trimesh.Trimesh, why_open: str, note_path: pathlib.Path,
            closed_path: pathlib.Path, mesh_path: pathlib.Path) -> tuple[trimesh.Trimesh, list[str]]:
    """``mesh`` closed by its winding number (:func:`objects.closing.close_surface`) and what was
    done, from the cache when this file was closed before (``note_path`` and the closed surface,
    ``closed_path``, in the file's frame); the note names ``mesh_path``, what the simulator loads.

    Raises ValueError naming the file when it cannot be closed or would be mostly made up.
    """
    cached = _cached_closing(note_path, closed_path)
    if cached is not None:
        return cached
    try:
        closed = close_surface(mesh)
    except ValueError as error:
        raise ValueError(f"{path}: {why_open}, and closing it by its winding number failed ({error}); "
                         "close the surface in a mesh editor") from None
    spanned = 100 * closed.spanned_fraction
    if closed.spanned_fraction > MAX_SPANNED_FRACTION:
        raise ValueError(f"{path}: {why_open}; closed by its winding number, {spanned:.0f} % of the surface "
                         f"would span openings (at most {100 * MAX_SPANNED_FRACTION:.0f} %): an open shell, "
                         "not a solid with holes; give its walls their thickness or close it in a mesh editor")
    specks = f", {closed.specks_dropped} specks of the level set dropped" if closed.specks_dropped else ""
    faces = (f"{len(closed.mesh.faces)} faces" if len(closed.mesh.faces) == closed.level_set_faces else
             f"{len(closed.mesh.faces)} faces, decimated from {closed.level_set_faces}")
    note = (f"{why_open}: closed it as the inside of its generalized winding number (libigl), meshed at "
            f"{closed.spacing_m * 1e3:.2g} mm (marching cubes; {faces}): {spanned:.1f} % of the surface spans "
            f"holes, sharp edges are rounded by up to ~{closed.spacing_m * 500:.2g} mm{specks}; check "
            f"{mesh_path} or close the file in a mesh editor")
    # Read back from the cache file, so that a run is the same whether this process closed the mesh
    # or found it closed there.
    _write_if_changed(closed_path, obj_text(closed.mesh, f"{path.name} closed by objects.closing"))
    _write_if_changed(note_path, json.dumps({"closing_version": CLOSING_VERSION, "note": note}))
    read_back = _cached_closing(note_path, closed_path)
    if read_back is None:
        raise ValueError(f"{path}: {why_open}; its closed surface did not read back closed from {closed_path}")
    return read_back


def _cached_closing(note_path: pathlib.Path, closed_path: pathlib.Path) -> tuple[trimesh.Trimesh, list[str]] | None:
    """The closed mesh and note written by :func:`_closed` for this file, or None (none, or made by
    another closing version)."""
    try:
        note = json.loads(note_path.read_text())
        if note.get("closing_version") != CLOSING_VERSION:
            return None
        mesh = trimesh.load(closed_path, file_type="obj", force="mesh", process=False)
    except (OSError, ValueError):
        return None
    if not (isinstance(mesh, trimesh.Trimesh) and mesh.is_watertight and mesh.volume > 0):
        return None
    return mesh, [note["note"]]


def _centred(path: pathlib.Path, mesh: trimesh.Trimesh) -> tuple[trimesh.Trimesh, np.ndarray]:
    """``mesh`` with the centre of its bounding box at the origin (a warning gives the shift), unless
    it lies within :data:`CENTRING_TOLERANCE_M` already, and the (3,) shift (the old origin's
    offset from the new, metres; zero when kept). The stand turns an object about its origin and
    the arm's reach is mapped around it; a file whose origin is a CAD part's corner or a scanner's
    would otherwise stand centimetres off the stand (a wrist wedged on a part 16 cm off)."""
    centre = mesh.bounds.mean(axis=0)
    if np.linalg.norm(centre) <= CENTRING_TOLERANCE_M:
        return mesh, np.zeros(3)
    mesh.apply_translation(-centre)
    x, y, z = centre * 1e3
    warnings.warn(f"{path}: the centre of its bounding box lies {np.linalg.norm(centre) * 1e3:.0f} mm from its "
                  "origin; moved the origin there, where the stand turns it (as for every registry and "
                  f"generated object): contacts and reconstructions are in that frame, a point of the file "
                  f"is one of theirs + ({x:.1f}, {y:.1f}, {z:.1f}) mm", stacklevel=1)
    return mesh, centre


def _settled(mesh_path: pathlib.Path, mesh: trimesh.Trimesh, comment: str) -> trimesh.Trimesh:
    """``mesh`` written to ``mesh_path`` as OBJ and read back as a later load of that file reads it,
    repaired until such a load has nothing left to repair (at most three rounds). Printed to 8
    decimals and shifted to its centre, a closed level set's vertices a micrometre apart merge and
    its slivers go: without this, each load of the cleaned copy (what ``--units`` hands on) repaired
    it again, with a warning, into a slightly different mesh."""
    for _ in range(3):
        _write_if_changed(mesh_path, obj_text(mesh, comment))
        reread = _read_mesh(mesh_path)
        repaired = reread.copy()
        try:
            if not _repair(mesh_path, repaired):
                return reread
        except _OpenSurface:
            return reread
        mesh = repaired
    _write_if_changed(mesh_path, obj_text(mesh, comment))
    return mesh


def _load_file(path: pathlib.Path, scale: float, cache_dir: pathlib.Path, keep_frame: bool) -> ObjectModel:
    if not (np.isfinite(scale) and scale > 0):
        raise ValueError(f"scale must be a positive finite number, got {scale}")
    mesh = _read_mesh(path)
    if scale != 1.0:
        mesh.apply_scale(scale)
    _check_size(path, mesh, scale)
    name = path.stem
    folder = _cache_folder(path, scale, cache_dir, keep_frame)
    folder.mkdir(parents=True, exist_ok=True)
    mesh_path, urdf_path = folder / f"{name}.obj", folder / f"{name}.urdf"
    comment = f"{name}: from {path} (scale {scale:g}), checked by objects.load"
    try:
        mesh, repairs = _repaired(path, mesh, scale)
    except _OpenSurface as open_surface:
        mesh, repairs = _closed(path, mesh, str(open_surface), folder / CLOSED_NOTE,
                                folder / f"{name}{CLOSED_SUFFIX}", mesh_path)
    repairs = list(dict.fromkeys(repairs))
    if repairs:
        # Attributed here, not to the caller: Python's default filter then shows it once per
        # process, where a command checks the file and then loads it again into the simulation.
        warnings.warn(f"{path}: repaired mesh: {'; '.join(repairs)}", stacklevel=1)
    shift = np.zeros(3)
    if not keep_frame:
        mesh, shift = _centred(path, mesh)
    mesh = _settled(mesh_path, mesh, comment)
    _write_if_changed(urdf_path, urdf_text(name, mesh_path.name, USER_RGBA))
    description = f"user mesh {path.name} (scale {scale:g}), {' x '.join(f'{e * 1e3:.1f}' for e in mesh.extents)} mm"
    return _model(name, description, mesh, mesh_path, urdf_path, file_shift_m=shift)
