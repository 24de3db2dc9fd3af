"""``python -m objects.generated``: the families' parameter ranges as a Markdown table (the one in
objects/README.md) and the names of both splits; ``--check`` builds every split shape and prints
its size and face count."""
from __future__ import annotations

import argparse

import numpy as np

from objects.generated.building import build_mesh, parse_name
from objects.generated.families import FAMILIES, Choice
from objects.generated.splits import HELD_OUT, TUNING


def _range_text(key: str, rule) -> str:
    if isinstance(rule, Choice):
        options = rule.options
        shown = f"{options[0]}..{options[-1]}" if len(options) > 6 else " / ".join(map(str, options))
        return f"{key} {shown}"
    if rule.unit == "m":
        return f"{key} {rule.low * 1e3:g}-{rule.high * 1e3:g} mm"
    if rule.unit == "deg":
        return f"{key} {rule.low:g}-{rule.high:g} deg"
    suffix = "" if rule.unit == "ratio" else f" {rule.unit}"
    return f"{key} {rule.low:g}-{rule.high:g}{suffix}"


def family_table() -> str:
    """Markdown table: family, what it is, parameter ranges."""
    lines = ["| family | shape | parameters (drawn uniformly) |", "|---|---|---|"]
    for family in FAMILIES.values():
        ranges = ", ".join(_range_text(key, rule) for key, rule in family.ranges.items())
        lines.append(f"| `{family.name}` | {family.summary} | {ranges} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="build every split shape and list it")
    args = parser.parse_args(argv)
    print(family_table())
    print(f"\ntuning ({len(TUNING)}): {', '.join(TUNING)}")
    print(f"\nheld-out ({len(HELD_OUT)}): {', '.join(HELD_OUT)}")
    if args.check:
        print("\n| name | bounding box (mm) | faces | volume (cm^3) |\n|---|---|---|---|")
        for name in TUNING + HELD_OUT:
            mesh = build_mesh(*parse_name(name))
            size = " x ".join(f"{e:.0f}" for e in np.asarray(mesh.extents) * 1e3)
            print(f"| `{name}` | {size} | {len(mesh.faces)} | {mesh.volume * 1e6:.0f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
