"""The ground-truth description of one object, as handed to the rest of the framework."""
from __future__ import annotations

import pathlib
from dataclasses import dataclass, field

import numpy as np
import trimesh


@dataclass(frozen=True, eq=False)
class ObjectModel:
    """A watertight object with its PyBullet URDF.

    Treat the mesh and arrays as read-only; :func:`objects.load` returns fresh copies every call.

    Attributes
    ----------
    name : str
        Registry name, or the file stem for a user mesh.
    description : str
        One line: what the object is and its size (mm).
    mesh : trimesh.Trimesh
        Watertight, outward normals, object frame, metres.
    mesh_path : pathlib.Path
        The OBJ file the URDF references (same geometry as ``mesh``).
    urdf_path : pathlib.Path
        URDF for PyBullet: one static link (mass 0) whose visual and collision use ``mesh_path``;
        collision is the exact triangle mesh (``concave="yes"``, see :func:`objects.files.urdf_text`).
    sharp_edges : (k, 2, 3) float
        Sharp feature edges (dihedral angle > 30 degrees) as segments, object frame, metres;
        shape (0, 2, 3) for smooth objects.
    centre_m : (3,) float
        Centre of the mesh's axis-aligned bounding box, object frame, metres.
    extent_m : (3,) float
        Size of that bounding box along x, y, z, metres.
    file_shift_m : (3,) float
        Where the object frame's origin lies in the mesh file's own frame (metres, after scaling): a
        point of the file is a point of the object frame plus this. Zero for registry and generated
        objects and for a file whose origin was kept (``objects.load`` centres a user mesh more than
        1 mm off).
    """

    name: str
    description: str
    mesh: trimesh.Trimesh
    mesh_path: pathlib.Path
    urdf_path: pathlib.Path
    sharp_edges: np.ndarray
    centre_m: np.ndarray
    extent_m: np.ndarray
    file_shift_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
