"""Ground-truth objects: watertight meshes (metres, object frame, z up) with PyBullet URDFs.

Public API: :func:`load` (registry name or mesh file -> :class:`ObjectModel`), :func:`names`,
:func:`sharp_edges`. No PyBullet import here: a URDF is a file, loading it is the simulator's job.
Sizes and accuracy of the registry objects: objects/README.md.
"""
from objects.catalogue import names
from objects.features import sharp_edges
from objects.loading import default_cache_dir, load
from objects.model import ObjectModel

__all__ = ["ObjectModel", "default_cache_dir", "load", "names", "sharp_edges"]
