"""The fixed tuning and held-out splits of generated objects (written out, so they never move).

Every family appears in both splits with different seeds: tuning seeds 0 and 1 (0, 1, 2 for the
fruit, one per kind), held-out seeds from 1000 on. Where a family has a categorical variant (the
fruit's kind, the prism's number of sides) the held-out split takes, for each tuning seed, the
first seed from 1000 on with the same variant, so both splits hold the same mix of variants
(``tests/test_generated_objects.py`` checks it). Choose every default on :data:`TUNING` only and
report :data:`HELD_OUT` separately.
"""
from __future__ import annotations

#: Parameters that name a variant of a family; the splits hold the same variants.
VARIANT_KEYS = {"fruit": "kind", "prism": "sides"}


def _names(seeds: dict[str, tuple[int, ...]]) -> tuple[str, ...]:
    return tuple(f"generated:{family}/{seed}" for family, family_seeds in seeds.items() for seed in family_seeds)


_PAIR, _HELD_PAIR = (0, 1), (1000, 1001)
TUNING_SEEDS: dict[str, tuple[int, ...]] = {
    "mug": _PAIR, "bowl": _PAIR, "tray": _PAIR, "bottle": _PAIR, "rounded_box": _PAIR, "chamfered_box": _PAIR,
    "l_tool": _PAIR, "t_tool": _PAIR, "plate": _PAIR, "lid": _PAIR, "torus": _PAIR, "ring": _PAIR,
    "blob": _PAIR, "fruit": (0, 1, 2), "wedge": _PAIR, "prism": _PAIR}
HELD_OUT_SEEDS: dict[str, tuple[int, ...]] = {
    "mug": _HELD_PAIR, "bowl": _HELD_PAIR, "tray": _HELD_PAIR, "bottle": _HELD_PAIR, "rounded_box": _HELD_PAIR,
    "chamfered_box": _HELD_PAIR, "l_tool": _HELD_PAIR, "t_tool": _HELD_PAIR, "plate": _HELD_PAIR,
    "lid": _HELD_PAIR, "torus": _HELD_PAIR, "ring": _HELD_PAIR, "blob": _HELD_PAIR,
    "fruit": (1003, 1000, 1004),  # pear, apple, lemon like tuning seeds 0, 1, 2
    "wedge": _HELD_PAIR,
    "prism": (1011, 1002)}  # 5 and 8 sides like tuning seeds 0, 1

#: Names of the tuning split (33), e.g. ``generated:mug/0``; family order, then seed.
TUNING: tuple[str, ...] = _names(TUNING_SEEDS)
#: Names of the held-out split (33), e.g. ``generated:mug/1000``.
HELD_OUT: tuple[str, ...] = _names(HELD_OUT_SEEDS)
