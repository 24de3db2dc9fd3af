"""The fixed tuning and held-out splits of generated objects.

Every family appears in both splits with different seeds (tuning: seeds 0 and 1; held-out: seeds
1000 and 1001), so the splits are equally varied and disjoint. Choose every default on
:data:`TUNING` only and report :data:`HELD_OUT` separately.
"""
from __future__ import annotations

from objects.generated.building import object_name
from objects.generated.families import FAMILIES

TUNING_SEEDS = (0, 1)
HELD_OUT_SEEDS = (1000, 1001)

#: Names of the tuning split, e.g. ``generated:mug/0``; family order, then seed.
TUNING: tuple[str, ...] = tuple(object_name(f, s) for f in FAMILIES for s in TUNING_SEEDS)
#: Names of the held-out split, e.g. ``generated:mug/1000``.
HELD_OUT: tuple[str, ...] = tuple(object_name(f, s) for f in FAMILIES for s in HELD_OUT_SEEDS)
