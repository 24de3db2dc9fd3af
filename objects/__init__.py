"""Ground-truth objects: watertight meshes (metres, object frame, z up) with PyBullet URDFs.

Public API: :func:`load` (registry name, generated name ``generated:<family>/<seed>`` or mesh
file -> :class:`ObjectModel`), :func:`names`, :func:`sharp_edges`, :func:`in_metres` and
:data:`UNITS` (the ``--units`` flag of every command that takes a mesh file), :func:`close_surface`
(what :func:`load` does with a mesh that stays open); the generated families
and the fixed tuning / held-out splits are in :mod:`objects.generated`. No PyBullet import here: a URDF is a file, loading it is the simulator's job.
Sizes and accuracy of the registry objects: objects/README.md.
"""
from objects.catalogue import names
from objects.closing import ClosedSurface, close_surface
from objects.features import sharp_edges
from objects.loading import (FILE_SHIFT_KEY, UNITS, default_cache_dir, file_label, in_metres, is_mesh_file_name, load,
                             load_as_recorded, shift_record, units_scale)
from objects.model import ObjectModel

__all__ = ["FILE_SHIFT_KEY", "UNITS", "ClosedSurface", "ObjectModel", "close_surface", "default_cache_dir", "file_label", "in_metres", "is_mesh_file_name", "load", "load_as_recorded", "names",
           "sharp_edges", "shift_record", "units_scale"]
