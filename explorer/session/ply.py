"""Triangle meshes as binary PLY files (float64 vertices, so coordinates are stored exactly)."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from explorer.session.line_files import write_atomically

_FACE_DTYPE = np.dtype([("count", "u1"), ("indices", "<i4", (3,))])


def mesh_arrays(mesh: Any) -> tuple[np.ndarray, np.ndarray]:
    """Validated ``(vertices, faces)`` of a mesh.

    Parameters
    ----------
    mesh : object with ``vertices`` and ``faces`` (e.g. ``trimesh.Trimesh``) or a ``(vertices, faces)`` pair
        vertices : (n, 3) float, metres; faces : (m, 3) int, indices into vertices.

    Returns
    -------
    vertices : (n, 3) float64
    faces : (m, 3) int32
    """
    if hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        vertices, faces = mesh.vertices, mesh.faces
    elif isinstance(mesh, (tuple, list)) and len(mesh) == 2:
        vertices, faces = mesh
    else:
        raise TypeError(
            f"mesh must have .vertices and .faces or be a (vertices, faces) pair, got {type(mesh).__name__}"
        )
    vertices = np.asarray(vertices, dtype=np.float64)
    faces_in = np.asarray(faces)
    if vertices.ndim != 2 or vertices.shape[1] != 3 or len(vertices) == 0:
        raise ValueError(f"mesh vertices must have shape (n, 3) with n >= 1, got {vertices.shape}")
    if not np.all(np.isfinite(vertices)):
        raise ValueError("mesh vertices must be finite")
    if faces_in.ndim != 2 or faces_in.shape[1] != 3 or len(faces_in) == 0:
        raise ValueError(f"mesh faces must have shape (m, 3) with m >= 1, got {faces_in.shape}")
    if faces_in.dtype.kind not in "iu":
        raise ValueError(f"mesh faces must be integer vertex indices, got dtype {faces_in.dtype}")
    if faces_in.min() < 0 or faces_in.max() >= len(vertices):
        raise ValueError(
            f"mesh faces must index vertices 0..{len(vertices) - 1}, got {faces_in.min()}..{faces_in.max()}"
        )
    return vertices, faces_in.astype(np.int32)


def write_ply(path: Path, vertices: np.ndarray, faces: np.ndarray) -> None:
    """Write a binary little-endian PLY file atomically (temporary file, fsync, rename).

    Parameters
    ----------
    vertices : (n, 3) float64
    faces : (m, 3) int
    """
    header = (
        "ply\n"
        "format binary_little_endian 1.0\n"
        "comment tactile-explore session reconstruction snapshot; metres, world frame\n"
        f"element vertex {len(vertices)}\n"
        "property double x\n"
        "property double y\n"
        "property double z\n"
        f"element face {len(faces)}\n"
        "property list uchar int vertex_indices\n"
        "end_header\n"
    )
    face_records = np.empty(len(faces), dtype=_FACE_DTYPE)
    face_records["count"] = 3
    face_records["indices"] = faces
    body = np.ascontiguousarray(vertices, dtype="<f8").tobytes() + face_records.tobytes()
    write_atomically(path, header.encode("ascii") + body)
