"""The registry of ground-truth objects: what each one is and the code that builds its mesh.

Every builder is deterministic and returns a watertight mesh in metres with the origin at the centre
of the analytic shape's bounding box and z up. Curved surfaces are tessellated with every vertex on
the analytic surface and spacings chosen so the chord error stays below 0.1 mm (checked in
tests/test_objects.py); objects/README.md tabulates sizes, face counts and errors.
"""
from __future__ import annotations

import pathlib
from dataclasses import dataclass
from typing import Callable

import trimesh

from objects.banana import BananaShape, banana_mesh
from objects.boxes import box_mesh
from objects.files import urdf_text
from objects.revolved import bowl_mesh, cylinder_mesh, sphere_mesh

DATA_DIR = pathlib.Path(__file__).resolve().parent / "data"

BOX_SIZE_M = (0.10, 0.07, 0.05)
SPHERE_RADIUS_M = 0.05
CYLINDER_RADIUS_M, CYLINDER_HEIGHT_M = 0.04, 0.12
BANANA = BananaShape()
BOWL_OUTER_RADIUS_M, BOWL_WALL_M = 0.08, 0.004
CEREAL_BOX_SIZE_M = (0.06, 0.16, 0.21)
COFFEE_CAN_RADIUS_M, COFFEE_CAN_HEIGHT_M = 0.05, 0.14
FLAT_SIZE_M = (0.20, 0.20, 0.01)


@dataclass(frozen=True)
class ObjectSpec:
    """How to make one registry object.

    Attributes
    ----------
    name : str
    description : str
        One line with the size in millimetres.
    build : callable () -> trimesh.Trimesh
        Deterministic mesh builder (object frame, metres).
    rgba : (4,) float
        Display colour in the URDF.
    """

    name: str
    description: str
    build: Callable[[], trimesh.Trimesh]
    rgba: tuple[float, float, float, float]


def _centred_bowl() -> trimesh.Trimesh:
    """Bowl shifted so its bounding box (outer pole to rim top) is centred on the origin."""
    mesh = bowl_mesh(BOWL_OUTER_RADIUS_M, BOWL_WALL_M, step_m=0.0054, rim_segments=8)
    rim_top = BOWL_WALL_M / 2
    mesh.apply_translation([0.0, 0.0, (BOWL_OUTER_RADIUS_M - rim_top) / 2])
    return mesh


def _centred_banana() -> trimesh.Trimesh:
    """Banana shifted so its bounding box is centred on the origin."""
    mesh = banana_mesh(BANANA, tolerance_m=7e-5, max_step_m=0.005)
    mesh.apply_translation(-mesh.bounds.mean(axis=0))
    return mesh


def _specs() -> list[ObjectSpec]:
    return [
        ObjectSpec("box", "box 100 x 70 x 50 mm with sharp edges",
                   lambda: box_mesh(BOX_SIZE_M, max_spacing_m=0.01), (0.80, 0.55, 0.30, 1.0)),
        ObjectSpec("sphere", "sphere, radius 50 mm",
                   lambda: sphere_mesh(SPHERE_RADIUS_M, step_m=0.004), (0.70, 0.70, 0.75, 1.0)),
        ObjectSpec("cylinder", "cylinder, radius 40 mm, height 120 mm, axis z, sharp rims",
                   lambda: cylinder_mesh(CYLINDER_RADIUS_M, CYLINDER_HEIGHT_M, arc_step_m=0.005,
                                         cap_step_m=0.008, side_step_m=0.01), (0.40, 0.55, 0.75, 1.0)),
        ObjectSpec("banana", "banana: spheres swept along a 165 mm arc bent 70 deg in the x-y plane, "
                             "radius 6 mm (stem) / 8 mm (tip) rising to 17.5 mm, about 179 mm tip to tip "
                             "along the arc", _centred_banana, (0.95, 0.85, 0.25, 1.0)),
        ObjectSpec("bowl", "hemispherical bowl, outer diameter 160 mm, wall 4 mm, rounded rim, opening +z",
                   _centred_bowl, (0.95, 0.95, 0.92, 1.0)),
        ObjectSpec("cereal_box", "cereal box 60 x 160 x 210 mm with sharp edges",
                   lambda: box_mesh(CEREAL_BOX_SIZE_M, max_spacing_m=0.02), (0.85, 0.25, 0.20, 1.0)),
        ObjectSpec("coffee_can", "coffee can: cylinder, diameter 100 mm, height 140 mm, axis z, sharp rims",
                   lambda: cylinder_mesh(COFFEE_CAN_RADIUS_M, COFFEE_CAN_HEIGHT_M, arc_step_m=0.0055,
                                         cap_step_m=0.01, side_step_m=0.01), (0.60, 0.60, 0.62, 1.0)),
        ObjectSpec("flat", "flat slab 200 x 200 x 10 mm; its top face (z = +5 mm) is the surface to explore",
                   lambda: box_mesh(FLAT_SIZE_M, max_spacing_m=0.02), (0.65, 0.50, 0.35, 1.0)),
    ]


SPECS: dict[str, ObjectSpec] = {spec.name: spec for spec in _specs()}


def names() -> tuple[str, ...]:
    """Names of the registry objects, in registry order."""
    return tuple(SPECS)


def spec(name: str) -> ObjectSpec:
    """The registry entry called ``name``; ValueError listing the valid names otherwise."""
    if name not in SPECS:
        raise ValueError(f"unknown object {name!r}; valid names: {', '.join(SPECS)} "
                         "(or give a path to an .obj, .stl or .ply mesh file)")
    return SPECS[name]


def mesh_filename(name: str) -> str:
    """File name of a registry object's committed mesh inside :data:`DATA_DIR`."""
    return f"{name}.obj"


def urdf_filename(name: str) -> str:
    """File name of a registry object's committed URDF inside :data:`DATA_DIR`."""
    return f"{name}.urdf"


def registry_urdf_text(name: str) -> str:
    """The URDF text committed for registry object ``name``."""
    return urdf_text(name, mesh_filename(name), spec(name).rgba)
