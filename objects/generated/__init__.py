"""Procedurally generated household-like objects: ``generated:<family>/<seed>``.

Public names: :data:`FAMILIES` (family name -> :class:`Family` with its parameter ranges),
:data:`TUNING` and :data:`HELD_OUT` (the fixed splits, lists of names), :func:`parse_name`,
:func:`parameters`, :func:`build_mesh`, :func:`is_generated_name`. Load one with
``objects.load("generated:mug/3")`` like a registry name. objects/README.md tabulates the families.
"""
from objects.generated.building import (SIZE_RANGE_M, build_mesh, is_generated_name, object_name, parameters,
                                        parse_name)
from objects.generated.families import FAMILIES, Choice, Family, Uniform
from objects.generated.splits import HELD_OUT, HELD_OUT_SEEDS, TUNING, TUNING_SEEDS, VARIANT_KEYS

__all__ = ["FAMILIES", "HELD_OUT", "HELD_OUT_SEEDS", "SIZE_RANGE_M", "TUNING", "TUNING_SEEDS", "Choice", "Family",
           "Uniform", "VARIANT_KEYS", "build_mesh", "is_generated_name", "object_name", "parameters", "parse_name"]
