"""Names, seeding and building of generated objects: ``generated:<family>/<seed>`` -> mesh and URDF.

The parameters of ``generated:mug/3`` are drawn from ``numpy.random.default_rng([crc32("mug"), 3])``
(PCG64, stable across numpy versions), so a name always means the same shape. The mesh is moved so
the centre of its axis-aligned bounding box is the origin (z up, the object standing as it would on
a table) and checked: watertight, outward normals, one body, largest side 6-20 cm.
"""
from __future__ import annotations

import pathlib
import re
import zlib

import numpy as np
import trimesh
from manifold3d import Manifold

from objects.generated.families import FAMILIES

PREFIX = "generated:"
#: Largest side of every generated object's bounding box, metres.
SIZE_RANGE_M = (0.06, 0.20)
#: Bumped whenever a builder changes, so cached files of an older generator are not reused.
GENERATOR_VERSION = 1
#: Long edges of flat faces are split to at most this length (keeps triangles of similar size).
MAX_EDGE_M = 0.012
RGBA = (0.55, 0.70, 0.55, 1.0)
_NAME = re.compile(r"^generated:([A-Za-z_]+)/(\d+)$")


def is_generated_name(name) -> bool:
    """Whether ``name`` is meant as a generated object (starts with ``generated:``)."""
    return isinstance(name, str) and name.startswith(PREFIX)


def parse_name(name: str) -> tuple[str, int]:
    """``"generated:mug/3"`` -> ``("mug", 3)``.

    Raises
    ------
    ValueError
        A malformed name (the message shows the syntax) or an unknown family (it lists the families).
    """
    match = _NAME.match(name) if isinstance(name, str) else None
    if match is None:
        raise ValueError(f"bad generated object name {name!r}: expected generated:FAMILY/SEED with SEED a "
                         f"non-negative integer, e.g. generated:mug/3; families: {', '.join(FAMILIES)}")
    family, seed = match.group(1), int(match.group(2))
    if family not in FAMILIES:
        raise ValueError(f"unknown generated family {family!r} in {name!r}; families: {', '.join(FAMILIES)}")
    return family, seed


def object_name(family: str, seed: int) -> str:
    """The name of one generated object: ``generated:<family>/<seed>``."""
    return f"{PREFIX}{family}/{int(seed)}"


def parameters(family: str, seed: int) -> dict:
    """The parameters of ``generated:<family>/<seed>`` (metres unless the family's range says otherwise)."""
    spec = FAMILIES[family]
    return spec.draw(np.random.default_rng([zlib.crc32(family.encode()), int(seed)]))


def build_mesh(family: str, seed: int) -> trimesh.Trimesh:
    """The checked mesh of ``generated:<family>/<seed>``: metres, origin at the bounding-box centre.

    Raises
    ------
    RuntimeError
        If the shape fails a check (a generator bug: every split shape is tested).
    """
    spec = FAMILIES[family]
    shape = spec.build(parameters(family, seed))
    mesh = _to_trimesh(shape)
    mesh.apply_translation(-mesh.bounds.mean(axis=0))
    problems = _problems(mesh)
    if problems:
        raise RuntimeError(f"{object_name(family, seed)}: generated mesh fails its checks: {'; '.join(problems)}")
    return mesh


def description(family: str, seed: int, mesh: trimesh.Trimesh) -> str:
    """One line: family summary, bounding box in mm."""
    size = " x ".join(f"{e * 1e3:.0f}" for e in mesh.extents)
    return f"generated {family} (seed {seed}): {FAMILIES[family].summary}; {size} mm"


def cache_folder(cache_dir: pathlib.Path, family: str, seed: int) -> pathlib.Path:
    """Where the OBJ and URDF of one generated object are written."""
    return cache_dir / "generated" / f"v{GENERATOR_VERSION}" / f"{family}-{int(seed)}"


def _to_trimesh(shape) -> trimesh.Trimesh:
    if isinstance(shape, Manifold):
        raw = shape.refine_to_length(MAX_EDGE_M).to_mesh()
        mesh = trimesh.Trimesh(np.asarray(raw.vert_properties, float)[:, :3], np.asarray(raw.tri_verts),
                               process=False)
    else:
        mesh = shape
    mesh.remove_unreferenced_vertices()
    return mesh


def _problems(mesh: trimesh.Trimesh) -> list[str]:
    problems = []
    if not mesh.is_watertight:
        problems.append("not watertight")
    if not mesh.is_winding_consistent:
        problems.append("inconsistent winding")
    if mesh.volume <= 0:
        problems.append(f"volume {mesh.volume:g} m^3 not positive")
    bodies = mesh.body_count
    if bodies != 1:
        problems.append(f"{bodies} bodies")
    largest = float(np.max(mesh.extents))
    if not SIZE_RANGE_M[0] <= largest <= SIZE_RANGE_M[1]:
        problems.append(f"largest side {largest * 1e3:.1f} mm outside "
                        f"{SIZE_RANGE_M[0] * 1e3:g}-{SIZE_RANGE_M[1] * 1e3:g} mm")
    return problems
