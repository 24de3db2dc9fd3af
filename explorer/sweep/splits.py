"""A sweep over the generated objects read per split and per family, against the issue-11 targets.

Rows are ``sweep.csv`` rows (:func:`explorer.sweep.results.read_csv`); an object's figure is the mean
over its finished seeds, a family's the mean over its objects. The targets (whole pipeline, 100
touches): every held-out object <= :data:`EVERY_OBJECT_MM`, median <= :data:`MEDIAN_MM`, coverage
>= :data:`COVERAGE_TARGET`. Objects that are not generated (registry names, mesh files) are left out.
"""
from __future__ import annotations

import functools
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

#: Issue 11's targets at 100 touches on the held-out split: every object, median (mm), coverage.
EVERY_OBJECT_MM = 3.0
MEDIAN_MM = 2.0
COVERAGE_TARGET = 0.8
SPLITS = ("tuning", "held-out")
#: The split summary's recess clause counts objects with at least this share of their area in recesses.
RECESS_SHARE = 0.1


def canonical_name(name: str) -> str:
    """A split member's name from itself or its sweep label (``generated-mug-3`` -> ``generated:mug/3``)."""
    return _split_labels().get(name, name)


@functools.cache
def _split_labels() -> dict[str, str]:
    """Sweep label -> name of every member of both splits (fixed lists: built once)."""
    import objects
    from objects.generated import HELD_OUT, TUNING

    return {objects.file_label(member): member for member in (*TUNING, *HELD_OUT)}


def split_of(name: str) -> str | None:
    """``"tuning"``, ``"held-out"`` or None (not in either fixed split); names or sweep labels."""
    from objects.generated import HELD_OUT, TUNING

    name = canonical_name(name)
    return "tuning" if name in TUNING else "held-out" if name in HELD_OUT else None


def family_of(name: str) -> str:
    """``"generated:mug/3"`` (or its label ``generated-mug-3``) -> ``"mug"``."""
    from objects.generated import parse_name

    return parse_name(canonical_name(name))[0]


@dataclass(frozen=True)
class ObjectResult:
    """One object's figures: means over its finished seeds (NaN where none has the value)."""

    name: str
    split: str
    family: str
    seeds: int
    rmse_mm: float
    rmse_mm_spread: tuple[float, float]
    coverage: float
    contacts: float
    chamfer_l1_mm: float
    fscore_2mm: float
    touches_to_3mm: float
    touches_to_2mm: float
    extra_handles: float = float("nan")
    recess_fraction: float = float("nan")
    recess_rmse_mm: float = float("nan")
    open_rmse_mm: float = float("nan")


def object_results(rows: Sequence[dict], strategy: str | None = None, normals: bool = True) -> list[ObjectResult]:
    """Per generated object of a split, its finished runs' means (``strategy`` None: the only one)."""
    groups: dict[str, list[dict]] = defaultdict(list)
    for row in rows:
        if (split_of(row["object"]) is None or not row["completed"] or row["normals"] != normals
                or (strategy is not None and row["strategy"] != strategy)):
            continue
        groups[canonical_name(row["object"])].append(row)
    strategies = {row["strategy"] for members in groups.values() for row in members}
    if strategy is None and len(strategies) > 1:
        raise ValueError(f"the sweep has several strategies ({', '.join(sorted(strategies))}): name one")
    out = []
    for name, members in groups.items():
        rmse = np.array([r["position_rmse_mm"] for r in members], float)
        out.append(ObjectResult(
            name, split_of(name), family_of(name), len(members), float(np.mean(rmse)),
            (float(np.min(rmse)), float(np.max(rmse))), _mean(members, "coverage"), _mean(members, "contacts"),
            _mean(members, "chamfer_l1_mm"), _mean(members, "fscore_2mm"),
            _mean(members, "touches_to_3mm"), _mean(members, "touches_to_2mm"), _mean(members, "extra_handles"),
            _mean(members, "recess_fraction"), _mean(members, "recess_rmse_mm"), _mean(members, "open_rmse_mm")))
    return out


def family_table(results: Sequence[ObjectResult]) -> str:
    """Markdown: one row per family, tuning and held-out side by side (RMSE mm, coverage)."""
    by = defaultdict(list)
    for r in results:
        by[(r.family, r.split)].append(r)
    families = sorted({r.family for r in results})
    lines = ["| family | tuning RMSE (mm) | tuning coverage | held-out RMSE (mm) | held-out coverage | "
             "held-out objects (RMSE mm, seeds min-max) |", "|---|---|---|---|---|---|"]
    for family in families:
        cells = [family]
        for split in SPLITS:
            members = by.get((family, split), [])
            cells += [_fmt(np.mean([m.rmse_mm for m in members])) if members else "-",
                      _fmt(np.nanmean([m.coverage for m in members])) if members else "-"]
        held = by.get((family, "held-out"), [])
        cells.append(", ".join(f"{m.name.split(':', 1)[1]} {m.rmse_mm:.2f} ({m.rmse_mm_spread[0]:.2f}-"
                               f"{m.rmse_mm_spread[1]:.2f})" for m in held) or "-")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _handles_summary(members: Sequence[ObjectResult]) -> str:
    """"; extra handles ...": the objects whose reconstructions have holes through their walls
    (mean over seeds above 0); nothing for sweeps from before the column."""
    known = [m for m in members if np.isfinite(m.extra_handles)]
    if not known:
        return ""
    holed = [m for m in known if m.extra_handles > 0]
    return (f"; extra handles: {len(holed)}/{len(known)}"
            + (f" ({', '.join(f'{m.name.split(chr(58), 1)[1]} {m.extra_handles:.1f}' for m in holed)})" if holed else ""))


def target_summary(results: Sequence[ObjectResult]) -> str:
    """One paragraph per split: median / max RMSE, objects over the limit, coverage, touches to 3 / 2 mm."""
    lines = []
    for split in SPLITS:
        members = [r for r in results if r.split == split]
        if not members:
            continue
        rmse = np.array([m.rmse_mm for m in members])
        worst = members[int(np.argmax(rmse))]
        coverage = np.array([m.coverage for m in members])
        over = [m for m in members if m.rmse_mm > EVERY_OBJECT_MM]
        reached3 = [m.touches_to_3mm for m in members if np.isfinite(m.touches_to_3mm)]
        reached2 = [m.touches_to_2mm for m in members if np.isfinite(m.touches_to_2mm)]
        lines.append(
            f"{split} ({len(members)} objects, {sum(m.seeds for m in members)} runs): RMSE median "
            f"{np.median(rmse):.2f} mm (target <= {MEDIAN_MM}), mean {np.mean(rmse):.2f}, max {worst.rmse_mm:.2f} "
            f"({worst.name}); over {EVERY_OBJECT_MM:g} mm: {len(over)}/{len(members)}"
            + (f" ({', '.join(f'{m.name.split(chr(58), 1)[1]} {m.rmse_mm:.2f}' for m in over)})" if over else "")
            + f"; coverage median {np.nanmedian(coverage):.2f}, objects >= {COVERAGE_TARGET}: "
            f"{int(np.sum(coverage >= COVERAGE_TARGET))}/{len(members)}; reached 3 mm: {len(reached3)}/{len(members)}"
            + (f" (mean {np.mean(reached3):.0f} touches)" if reached3 else "")
            + f", 2 mm: {len(reached2)}/{len(members)}" + (f" (mean {np.mean(reached2):.0f} touches)" if reached2 else "")
            + _handles_summary(members) + _recess_summary(members))
    return "\n\n".join(lines)


def _recess_summary(members: Sequence[ObjectResult]) -> str:
    """"; the k objects with recesses ...": over the objects with at least ``RECESS_SHARE`` of their
    area in recesses (cups, bowls, holes), the error in them against elsewhere (truth ->
    reconstruction RMS); nothing for sweeps from before the column."""
    known = [m for m in members if m.recess_fraction >= RECESS_SHARE and np.isfinite(m.recess_rmse_mm)
             and np.isfinite(m.open_rmse_mm)]
    if not known:
        return ""
    inside, outside = [m.recess_rmse_mm for m in known], [m.open_rmse_mm for m in known]
    return (f"; the {len(known)} objects with recesses (>= {RECESS_SHARE:.0%} of the area): truth -> "
            f"reconstruction RMS {np.mean(inside):.2f} mm in them, {np.mean(outside):.2f} mm elsewhere (means)")


def split_figure(curves: Sequence[tuple[str, list[dict]]], path: Path) -> Path:
    """Position RMSE against touches, tuning and held-out side by side.

    Parameters
    ----------
    curves : sequence of (object name, error_curve)
        One entry per finished run; ``error_curve`` as in ``metrics.json``.
    path : Path
        PNG to write. Thin lines: one family (mean over its objects and seeds); thick: the median
        over the split's objects at the touch counts every run evaluated.
    """
    from reconstruction.figures.canvas import new_figure, save_png

    per_split: dict[str, dict[str, dict[int, list[float]]]] = {s: defaultdict(lambda: defaultdict(list)) for s in SPLITS}
    per_object: dict[str, dict[str, dict[int, list[float]]]] = {s: defaultdict(lambda: defaultdict(list)) for s in SPLITS}
    for name, curve in curves:
        split = split_of(name)
        if split is None:
            continue
        for point in curve:
            per_object[split][canonical_name(name)][int(point["touches"])].append(point["position_rmse_mm"])
    families = sorted({family_of(name) for split in SPLITS for name in per_object[split]})
    # one colour and line style per family in both panels (ten colours, then dashed)
    style = {family: (f"C{index % 10}", "-" if index < 10 else "--") for index, family in enumerate(families)}
    figure = new_figure(11.0, 4.3, layout="constrained")
    axes = figure.subplots(1, 2, sharey=True)
    for ax, split in zip(axes, SPLITS):
        objects_ = per_object[split]
        for name, at in objects_.items():
            for n, values in at.items():
                per_split[split][family_of(name)][n].append(float(np.mean(values)))
        for family, at in sorted(per_split[split].items()):
            touches = sorted(at)
            colour, line = style[family]
            ax.plot(touches, [np.mean(at[n]) for n in touches], lw=0.9, alpha=0.7, color=colour, ls=line, label=family)
        common = sorted(set.intersection(*(set(at) for at in objects_.values()))) if objects_ else []
        if common:
            median = [np.median([np.mean(at[n]) for at in objects_.values()]) for n in common]
            ax.plot(common, median, lw=2.8, color="black", marker="o", label="median over objects")
        ax.axhline(EVERY_OBJECT_MM, ls="--", lw=0.8, color="grey")
        ax.axhline(MEDIAN_MM, ls=":", lw=0.8, color="grey")
        ax.set_yscale("log")
        ax.set_xlabel("touches")
        ax.set_title(f"{split} split ({len(objects_)} objects)")
    axes[0].set_ylabel("position RMSE (mm)")
    for ax in axes:
        ax.legend(fontsize=7, ncol=2)
    return save_png(figure, path)


def _mean(rows: Sequence[dict], key: str) -> float:
    values = [r[key] for r in rows if r.get(key) is not None]
    return float(np.mean(values)) if values else float("nan")


def _fmt(value: float) -> str:
    return "-" if not np.isfinite(value) else f"{value:.2f}"
