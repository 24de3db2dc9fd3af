"""The outputs a finished (or stopped) run and a replay both write: mesh, error metrics, figures;
and how every output file is written: whole or not at all.

Each file goes through :func:`common.atomic_files.write_bytes_atomically` (temporary file, fsync,
``os.replace``): a reader finds the previous content or the new one, never a truncated file.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from common.atomic_files import write_bytes_atomically
from explorer.evaluation import reconstruction_errors


def write_bytes(path: Path, data: bytes) -> Path:
    """Replace ``path`` by ``data`` atomically; returns ``path``."""
    return write_bytes_atomically(path, data)


def write_text(path: Path, text: str) -> Path:
    """Replace ``path`` by ``text`` (UTF-8) atomically."""
    return write_bytes(path, text.encode("utf-8"))


def write_json(path: Path, data: Any) -> Path:
    """Replace ``path`` by ``data`` as indented JSON, atomically (``data`` must be JSON-ready)."""
    return write_text(path, json.dumps(data, indent=2))


def export_mesh(mesh, path: Path) -> Path:
    """Write a trimesh mesh to ``path`` (format from the suffix, e.g. ``.ply``) atomically."""
    path = Path(path)
    return write_bytes(path, mesh.export(file_type=path.suffix.lstrip(".").lower()))


def write_mesh(gpis, resolution: int, out_dir: Path, metrics: dict, symmetry: bool = False,
               refine_steps: int | None = None):
    """Mesh the GPIS mean surface into ``out_dir/reconstruction.ply``; returns the mesh or None.

    A field with no zero level set (or no contacts) gives None, with ``reconstruction_error`` in
    ``metrics`` saying why when meshing failed. ``symmetry``: mesh with the contacts' symmetric
    images (``GPIS.mesh(symmetry=...)``); ``metrics["reconstruction_symmetry"]`` says what was
    found (``none``, ``mirror`` or ``revolution``, with the number of transforms and of contacts on a
    feature the revolution or its mirror across the axis does not hold for, ``feature_contacts``: a
    mug's handle, an apple's stem) and how many
    contacts' images were left out because the field with the images put those contacts in free space
    (``disputed_contacts``).
    ``refine_steps``: as ``GPIS.mesh`` takes it (the loop passes its ``reconstruction_refine_steps``).
    """
    if not gpis.n_contacts:
        return None
    try:
        options = {}
        from reconstruction.gpis import GPIS

        if symmetry and isinstance(gpis, GPIS) and gpis.use_normals:  # a PartitionedGPIS meshes plainly
            found = gpis.symmetry()
            metrics["reconstruction_symmetry"] = dict(
                kind=found.kind, transforms=len(found.transforms) + len(found.body_transforms),
                feature_contacts=int(found.in_feature(gpis.contact_points).sum()))
            options["symmetry"] = found
        mesh = gpis.mesh(resolution=resolution, refine_steps=refine_steps, **options)
        if "symmetry" in options:
            metrics["reconstruction_symmetry"]["disputed_contacts"] = len(
                mesh.metadata.get("symmetry_disputed_contacts", ()))
        export_mesh(mesh, Path(out_dir) / "reconstruction.ply")
    except ValueError as exc:
        metrics["reconstruction_error"] = str(exc)
        return None
    return mesh


def reconstruction_counts(built) -> dict:
    """``metrics.json``'s counts of what the reconstruction (:class:`explorer.loop.Reconstruction`)
    took differently from the loop's field: contacts moved in where the pad bridged
    (``bridged_contacts``), free-space rows of the approach lines (``swept_free_space_rows``), the
    contacts left out because they stood off on the pad's rim (``rim_standoff_contacts``) and their
    touches (``rim_standoff_touches``, indices), and contacts moved out where the pad bore on one
    point (``indented_contacts``)."""
    return dict(bridged_contacts=built.bridged_contacts, indented_contacts=built.indented_contacts,
                swept_free_space_rows=built.swept_rows,
                rim_standoff_contacts=len(built.rim_standoff_touches),
                rim_standoff_touches=[int(i) for i in built.rim_standoff_touches])


def add_errors(metrics: dict, mesh, truth, points: np.ndarray, normals: np.ndarray,
               kept: np.ndarray | None = None) -> None:
    """Errors of ``mesh`` and of the contacts (n, 3) against the true surface, into ``metrics``;
    ``kept`` (n,) bool: the contacts the reconstruction used (see :func:`kept_contacts`)."""
    if mesh is not None and truth is not None:
        metrics.update(reconstruction_errors(mesh, truth, points, normals, kept))


def kept_contacts(contacts, set_aside_touches) -> np.ndarray:
    """(n,) bool over ``contacts`` (touch records with ``index``, in order): not among the touch
    indices the reconstruction set aside (``rim_standoff_touches``)."""
    aside = {int(i) for i in set_aside_touches}
    return np.array([c.index not in aside for c in contacts], bool)


def write_figures(out_dir: Path, gpis, mesh, truth, points: np.ndarray, use_normals: bool,
                  curve=(), strategy: str = "") -> None:
    """``reconstruction_error.png`` (with a truth), ``error_vs_touches.png`` (with a curve of
    ``(touches, position_rmse_mm, normal_rmse_deg)``) and ``potential_slice.png``.

    Raises ValueError when a figure cannot be framed (e.g. too few contacts).
    """
    from reconstruction import figures

    out_dir = Path(out_dir)
    if truth is not None:
        figures.error_coloured_views(mesh, truth, points, out_dir / "reconstruction_error.png")
    if curve:
        errors = np.array([[p * 1e-3 for _, p, _ in curve]])
        figures.error_vs_touches({strategy: errors}, out_dir / "error_vs_touches.png",
                                 touches=[n for n, _, _ in curve])
    # Without the truth the slice goes through the contacts (a one-sided touch set may not reach z = 0).
    offset_m = 0.0 if truth is not None or not len(points) else float(np.median(points[:, 2]))
    figures.potential_slice(gpis if use_normals else None, None if use_normals else gpis, truth,
                            offset_m=offset_m, path=out_dir / "potential_slice.png")
