"""Reconstruction faithfulness on the generated object splits: error against the number of contacts.

For every object of a set (``tuning`` / ``held-out``: the fixed splits of :mod:`objects.generated`;
``registry``: the eight registry objects), N contacts (100 / 200 / 400) are sampled area-uniformly
from the ground truth with the default sensor noise of :mod:`reconstruction.synthetic_contacts`
(contact draws = sampling seeds 100, 101, ...), reconstructed by a GPIS method, meshed over the
object's box grown by 20 % of its largest side, and compared with the truth. Draws are nested: the
N contacts of a draw are the first N of one seeded sequence of ``NESTED_POOL`` (``sample_contacts``
with ``pool``), so a draw's 400 contacts extend its 200 and those its 100, as an exploration's do,
and "worse with more contacts" is a statement about contacts added, not about another draw's luck
(``--independent-draws``: each N drawn on its own, the design before 2026-12).

Metrics (both meshes sampled area-uniformly, ``--samples`` points per direction, distances to the
closest point of the other surface; definitions of :func:`reconstruction.metrics.shape_metrics`):

* RMSE: mean of the two directional RMS distances (as :func:`reconstruction.metrics.surface_error`);
* p99: 99th percentile of the reconstruction -> truth distances (phantom surface shows here);
* Chamfer: mean of the two directional mean distances (L1 Chamfer, mm);
* F@1, F@2: F-score at 1 and 2 mm (harmonic mean of precision, the share of reconstruction samples
  within the threshold of the truth, and recall, the share of truth samples within it of the
  reconstruction);
* extra handles: genus of the reconstruction minus the truth's (:mod:`reconstruction.topology`):
  holes through thin walls and bridges across gaps, which the distances average away;
* RMSE standard error: the scatter the samples alone give the RMSE
  (:func:`reconstruction.metrics.symmetric_rmse_standard_error`). A draw is counted worse with more
  contacts when its RMSE grows from one N to the next at all, by more than 0.01 mm, and by more
  than twice the standard error of the difference (the samples cannot tell smaller steps apart).

Prints per-family tables and a summary against the issue-10 targets per set, writes every result as
JSON lines to ``--out`` (re-used: finished cases are not recomputed) and a figure of RMSE against
the number of contacts, sets side by side.

    python -m scripts.gpis_faithfulness_benchmark --set tuning,held-out --quick --out /tmp/faithful
"""
from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

import objects
from objects.proximity import MeshProximity
from objects.sampling import sample_surface
from reconstruction.confidence import DEFAULT_MAX_STD_M
from reconstruction.gpis import GPIS
from reconstruction.metrics import shape_metrics, symmetric_rmse_standard_error
from reconstruction.outside_evidence import add_outside_evidence
from reconstruction.symmetry import SymmetrySettings, find_symmetry
from reconstruction.synthetic_contacts import sample_contacts
from reconstruction.topology import surface_topology

#: The known rough location: the object's box grown by this fraction of its largest side.
BOUNDS_PADDING = 0.2
FIRST_DRAW_SEED = 100
#: Nested draws take their contacts from the front of one seeded sequence this long.
NESTED_POOL = 4000


def _old_default(bounds):
    """The GPIS default before issue 10: thin plate, normal noise 0.2 for every contact, trend 3."""
    return GPIS(kernel="thin_plate", noise=5e-4, normal_noise=0.2, trend=3.0, bounds=bounds,
                opposing_normal_noise=None)


def _current_default(bounds):
    return GPIS(bounds=bounds)


class _Configured:
    """A GPIS method: keyword arguments for GPIS, optionally a data-chosen length scale."""

    def __init__(self, **kwargs):
        self.kwargs = kwargs

    def __call__(self, bounds):
        return _Fitter(bounds, self.kwargs)


class _Fitter:
    def __init__(self, bounds, kwargs):
        self.bounds, self.kwargs = bounds, kwargs

    def fit(self, points, normals):
        kwargs = dict(self.kwargs)
        family = kwargs.pop("ml_matern32", None)
        if family is None:
            return GPIS(bounds=self.bounds, **kwargs).fit(points, normals)
        from reconstruction.kernels import ConstantKernel, Matern32Kernel, SumKernel
        from reconstruction.scale_selection import choose_length_scale

        make = lambda length: SumKernel(Matern32Kernel(length, length / np.sqrt(3.0)),  # noqa: E731
                                        ConstantKernel(0.05))
        fit = lambda kernel: GPIS(kernel=kernel, bounds=self.bounds, **kwargs).fit(points, normals)  # noqa: E731
        best, _ = choose_length_scale(fit, make, family)
        return fit(make(best))


#: Methods by name: bounds -> an object whose fit(points, normals) returns a fitted GPIS.
METHODS = {"default": _current_default, "old-default": _old_default,
           "normal-noise-0.1": _Configured(normal_noise=0.1, opposing_normal_noise=None),
           "normal-noise-0.05": _Configured(normal_noise=0.05, opposing_normal_noise=None),
           "matern32-ml": _Configured(ml_matern32=(0.02, 0.04, 0.08, 0.16), opposing_normal_noise=None),
           # the loop's reconstruction setting (LoopConfig.reconstruction_wall_gain) on sampled contacts
           "wall-gain-3": _Configured(opposing_gradient_gain=3.0)}
#: The default GPIS meshed with only its confident faces (``GPIS.mesh(max_std_m=...)``), by bound.
CONFIDENT_BOUNDS_MM = {"confident": DEFAULT_MAX_STD_M * 1e3, "confident-1.5": 1.5, "confident-2.0": 2.0,
                       "confident-2.5": 2.5, "confident-3.0": 3.0}
METHODS.update({name: _current_default for name in CONFIDENT_BOUNDS_MM})
#: The default GPIS meshed without the outside evidence beyond the contacts' hull (the plain mean,
#: ``GPIS.mesh(outside_evidence=False)``; BENCHMARKS.md, issue 10).
METHODS["no-outside-evidence"] = _current_default
MESH_OPTIONS = {"no-outside-evidence": {"outside_evidence": False}}
#: The outside evidence with other settings, added to the fit before the plain mesh (its defaults
#: were chosen among these).
EVIDENCE_VARIANTS = {"outside-evidence-0.25": dict(facet_fraction=0.25),
                     "outside-evidence-0.5": dict(facet_fraction=0.5), "outside-evidence-1.0": dict(facet_fraction=1.0),
                     "outside-evidence-open-any": dict(max_open_angle_rad=None),
                     "outside-evidence-open-90": dict(max_open_angle_rad=float(np.radians(90.0))),
                     "outside-evidence-open-150": dict(max_open_angle_rad=float(np.radians(150.0))),
                     "outside-evidence-no-tangent": dict(tangent_margin_m=None),
                     "outside-evidence-tilt-0": dict(normal_tolerance_rad=0.0),
                     "outside-evidence-tilt-25": dict(normal_tolerance_rad=float(np.radians(25.0))),
                     # the margin from the facet's size alone (the default before the local gaps)
                     "outside-evidence-facet-only": dict(local_neighbours=None),
                     # without the supporting face planes (the default before them)
                     "outside-evidence-no-faces": dict(face_tolerance_rad=None)}
METHODS.update({name: _current_default for name in EVIDENCE_VARIANTS})
#: The default GPIS meshed with the contacts' symmetric images (``GPIS.mesh(symmetry=True)``), and so
#: without the cut at the contacts' whole flat faces (``cut_at_faces=False``: the mesh before it).
METHODS["symmetry"] = METHODS["symmetry-uncut"] = _current_default
MESH_OPTIONS["symmetry"] = {"symmetry": True}
MESH_OPTIONS["symmetry-uncut"] = {"symmetry": True, "cut_at_faces": False}
#: ... with the images observed under the GPIS's own thin-plate kernel (``image_kernel=None``: the
#: mesh before the Matern-3/2 image kernel).
METHODS["symmetry-thin-plate-images"] = _Configured(image_kernel=None)
MESH_OPTIONS["symmetry-thin-plate-images"] = {"symmetry": True}
#: The symmetry found with other settings (``find_symmetry(..., settings)``): without a feature left out
#: of an axis of revolution (a mug's handle; the search before it), without the axis polished by its
#: profile (the search before it: no axis polished, refused or accepted), without a refused axis
#: rescued by its profile (the search before that), with the mirror across an axis placed by the
#: images' score and holding for every contact (before it was placed by the profile), with the mirror
#: planes' crossing axis as found (before it was polished by its profile) or polished and meshed as a
#: revolution alone, with competing images ranked by their contacts' left-out agreement (not kept), or
#: with the first of competing images kept instead of their mean (before the mean).
SYMMETRY_SETTINGS = {"symmetry-no-feature": SymmetrySettings(max_feature_share=None),
                     "symmetry-unpolished": SymmetrySettings(profile_scales_m=()),
                     "symmetry-unrescued": SymmetrySettings(rescue_starts=None),
                     "symmetry-mirror-by-score": SymmetrySettings(mirror_by_profile=False),
                     "symmetry-planes-unpolished": SymmetrySettings(polish_planes_axis=None),
                     "symmetry-planes-revolution": SymmetrySettings(polish_planes_axis="revolution"),
                     "symmetry-images-ranked": SymmetrySettings(rank_images=True),
                     "symmetry-images-first": SymmetrySettings(merge_images=False)}
METHODS.update({name: _current_default for name in SYMMETRY_SETTINGS})
MESH_OPTIONS.update({name: {"outside_evidence": False} for name in EVIDENCE_VARIANTS})  # rows already added


def _partitioned(**kwargs):
    """A :class:`reconstruction.partitioned_gpis.PartitionedGPIS` method with these settings."""
    def make(bounds):
        from reconstruction.partitioned_gpis import PartitionedGPIS

        return PartitionedGPIS(bounds, **kwargs)
    return make


#: Partitions of unity of local GPIS fits (issue 10, "Partitioned GPIS" in BENCHMARKS.md).
METHODS.update({"partitioned": _partitioned(),
                "partitioned-fine": _partitioned(max_cell_contacts=10, min_cell_m=0.005),
                "partitioned-matern": _partitioned(local_kernel="matern32", scale_factor=0.5),
                "partitioned-matern-ml": _partitioned(local_kernel="matern32-ml"),
                "partitioned-fine-matern-ml": _partitioned(local_kernel="matern32-ml", max_cell_contacts=10,
                                                           min_cell_m=0.005)})


def object_names(which: str, quick: bool) -> list[str]:
    """Names in a set; ``quick`` keeps the first object of each family (one per registry object)."""
    from objects.generated import HELD_OUT, TUNING

    if which == "registry":
        return ["box", "sphere", "cylinder", "banana"] if quick else list(objects.names())
    names = {"tuning": TUNING, "held-out": HELD_OUT}.get(which)
    if names is None:
        raise SystemExit(f"unknown set {which!r}: use tuning, held-out or registry")
    if not quick:
        return list(names)
    seen, out = set(), []
    for name in names:
        family = family_of(name)
        if family not in seen:
            seen.add(family)
            out.append(name)
    return out


def family_of(name: str) -> str:
    return name.split(":", 1)[1].split("/")[0] if name.startswith("generated:") else name


def object_bounds(mesh) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = mesh.bounds
    pad = BOUNDS_PADDING * float(np.max(hi - lo))
    return lo - pad, hi + pad


def _directional(source, target_proximity: MeshProximity, target_normals, n: int, rng):
    points, faces = sample_surface(source, n, rng)
    _, distance, target_faces = target_proximity.query(points)
    cos = np.einsum("ij,ij->i", source.face_normals[faces], target_normals[target_faces])
    return distance, cos


def compare(reconstruction, truth, n_samples: int, seed: int) -> dict:
    """The benchmark's metrics of one reconstruction (see the module docstring); mm."""
    rng = np.random.default_rng(seed)
    forward, forward_cos = _directional(reconstruction, MeshProximity(truth), truth.face_normals,
                                        n_samples, rng)
    backward, backward_cos = _directional(truth, MeshProximity(reconstruction),
                                          reconstruction.face_normals, n_samples, rng)
    standard = shape_metrics(forward, backward, forward_cos, backward_cos)
    rms = lambda v: float(np.sqrt(np.mean(np.square(v))))  # noqa: E731
    return dict(rmse_mm=1e3 * (rms(forward) + rms(backward)) / 2,
                rmse_se_mm=1e3 * symmetric_rmse_standard_error(forward, backward),
                p99_mm=1e3 * float(np.quantile(forward, 0.99)),
                chamfer_mm=standard.chamfer_l1_mm, f1=standard.fscore_1mm, f2=standard.fscore_2mm,
                extra_handles=surface_topology(reconstruction).genus - surface_topology(truth).genus)


def run_case(method: str, name: str, truth, n_contacts: int, draw: int, resolution: int,
             n_samples: int, nested: bool = True) -> dict:
    """One reconstruction scored (the module docstring's metrics); ``nested``: the draw's contacts
    are the first ``n_contacts`` of its ``NESTED_POOL`` sequence, else drawn on their own."""
    seed = FIRST_DRAW_SEED + draw
    if nested and n_contacts > NESTED_POOL:
        raise ValueError(f"nested draws hold at most {NESTED_POOL} contacts, asked for {n_contacts}: "
                         "use --independent-draws")
    points, normals, _, _ = sample_contacts(truth, n_contacts, seed=seed, pool=NESTED_POOL if nested else None)
    t0 = time.perf_counter()
    gp = METHODS[method](object_bounds(truth)).fit(points, normals)
    if method in EVIDENCE_VARIANTS:
        add_outside_evidence(gp, **EVIDENCE_VARIANTS[method])
    fit_s = time.perf_counter() - t0
    bound_mm = CONFIDENT_BOUNDS_MM.get(method)
    try:
        options = dict(MESH_OPTIONS.get(method, {}))
        if bound_mm is not None:
            options["max_std_m"] = 1e-3 * bound_mm
        if method in SYMMETRY_SETTINGS:
            options["symmetry"] = find_symmetry(gp.contact_points, gp.contact_normals, gp, SYMMETRY_SETTINGS[method])
        mesh = gp.mesh(resolution=resolution, **options)
        metrics = compare(mesh, truth, n_samples, seed)
    except ValueError as exc:  # no surface in the box: count as a failure, never drop it
        metrics = dict(rmse_mm=float("nan"), p99_mm=float("nan"), chamfer_mm=float("nan"),
                       f1=0.0, f2=0.0, error=str(exc))
    return dict(method=method, object=name, family=family_of(name), contacts=n_contacts, draw=draw,
                draws="nested" if nested else "independent", fit_s=fit_s, resolution=resolution, **metrics)


def _key(row: dict) -> tuple:
    # rows written before nested draws existed were independent draws
    return (row["method"], row["object"], row["contacts"], row["draw"], row["resolution"],
            row.get("draws", "independent"))


def load_results(path: Path | None) -> dict:
    if path is None or not path.exists():
        return {}
    rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    return {_key(r): r for r in rows}


def family_table(rows: list[dict], contacts: list[int]) -> str:
    by = defaultdict(list)
    for r in rows:
        by[(r["family"], r["contacts"])].append(r)
    head = "| family | " + " | ".join(f"{n}: RMSE / p99 / Chamfer / F@1 / F@2" for n in contacts) + " |"
    lines = [head, "|---|" + "---|" * len(contacts)]
    for family in sorted({r["family"] for r in rows}):
        cells = []
        for n in contacts:
            v = by.get((family, n), [])
            if not v:
                cells.append("-")
                continue
            m = {k: float(np.nanmean([r[k] for r in v])) for k in ("rmse_mm", "p99_mm", "chamfer_mm", "f1", "f2")}
            cells.append(f"{m['rmse_mm']:.2f} / {m['p99_mm']:.1f} / {m['chamfer_mm']:.2f} / "
                         f"{m['f1']:.2f} / {m['f2']:.2f}")
        lines.append(f"| {family} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _handles(per_object: dict, n: int) -> str:
    """"; extra handles ...": objects whose reconstruction has more handles than the truth (rows
    written before the column existed and failed cases are left out)."""
    extra = [np.mean([r["extra_handles"] for r in v]) for (o, c), v in per_object.items()
             if c == n and all("extra_handles" in r for r in v)]
    if not extra:
        return ""
    return (f"; objects with extra handles: {int(np.sum(np.array(extra) > 0))}/{len(extra)} "
            f"(mean over draws: median {np.median(extra):.1f}, max {np.max(extra):.1f})")


def summary(rows: list[dict], contacts: list[int]) -> str:
    """Against the issue-10 targets: per-object means over draws at each N (the p99 also by the
    worst draw), monotonicity per draw."""
    per_object = defaultdict(list)
    for r in rows:
        per_object[(r["object"], r["contacts"])].append(r)
    out = []
    for n in contacts:
        rmse = [np.nanmean([r["rmse_mm"] for r in v]) for (o, c), v in per_object.items() if c == n]
        p99 = [np.nanmean([r["p99_mm"] for r in v]) for (o, c), v in per_object.items() if c == n]
        p99_worst = [np.nanmax([r["p99_mm"] for r in v]) for (o, c), v in per_object.items() if c == n]
        if rmse:
            worst = max(((np.nanmean([r["rmse_mm"] for r in v]), o) for (o, c), v in per_object.items()
                         if c == n))
            out.append(f"{n} contacts: RMSE median {np.median(rmse):.2f} mm, mean {np.mean(rmse):.2f}, "
                       f"max {worst[0]:.2f} ({worst[1]}); objects over 1.5 mm: "
                       f"{int(np.sum(np.array(rmse) > 1.5))}/{len(rmse)}; p99 (mean of draws) max "
                       f"{np.max(p99):.1f} mm, objects over 3 mm: {int(np.sum(np.array(p99) > 3))}/{len(p99)} "
                       f"(by the worst draw {int(np.sum(np.array(p99_worst) > 3))}){_handles(per_object, n)}")
    steps = worse_with_more(rows, contacts)
    above_noise = [s for s in steps if s["beyond_noise"]]
    out.append(f"worse with more contacts: {len(steps)} steps, {sum(s['by_mm'] > 0.01 for s in steps)} by more "
               f"than 0.01 mm, {len(above_noise)} by more than twice the standard error of the difference"
               + (" (" + "; ".join(f"{s['object']} draw {s['draw']}: {s['from']}->{s['to']} {s['rmse_mm'][0]:.2f}->"
                                   f"{s['rmse_mm'][1]:.2f}" for s in above_noise) + ")" if above_noise else ""))
    return "\n".join(out)


def worse_with_more(rows: list[dict], contacts: list[int]) -> list[dict]:
    """Every step from one number of contacts to the next at which a draw's RMSE grew.

    Returns
    -------
    list of dict: ``object``, ``draw``, ``from``, ``to`` (contacts), ``rmse_mm`` (before, after),
    ``by_mm`` (the growth) and ``beyond_noise``: the growth exceeds 0.01 mm and twice the standard
    error of the difference (rows without ``rmse_se_mm``: the 0.01 mm alone).
    """
    by_draw = {(r["object"], r["draw"], r["contacts"]): r for r in rows}
    steps = []
    for (o, d, c), row in sorted(by_draw.items()):
        nxt = [m for m in contacts if m > c]
        after = by_draw.get((o, d, nxt[0])) if nxt else None
        if after is None or not after["rmse_mm"] > row["rmse_mm"]:
            continue
        growth = after["rmse_mm"] - row["rmse_mm"]
        noise = 2.0 * float(np.hypot(row.get("rmse_se_mm", 0.0), after.get("rmse_se_mm", 0.0)))
        steps.append({"object": o, "draw": d, "from": c, "to": nxt[0], "by_mm": growth,
                      "rmse_mm": (row["rmse_mm"], after["rmse_mm"]), "beyond_noise": growth > max(0.01, noise)})
    return steps


def figure(all_rows: dict[str, list[dict]], contacts: list[int], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    sets = list(all_rows)
    fig, axes = plt.subplots(1, len(sets), figsize=(5.5 * len(sets), 4.2), sharey=True, squeeze=False)
    for ax, which in zip(axes[0], sets):
        rows = all_rows[which]
        for index, method in enumerate(sorted({r["method"] for r in rows})):
            colour = f"C{index}"
            per_family = defaultdict(lambda: defaultdict(list))
            for r in rows:
                if r["method"] == method:
                    per_family[r["family"]][r["contacts"]].append(r["rmse_mm"])
            for family, values in per_family.items():
                ns = [n for n in contacts if n in values]
                ax.plot(ns, [np.nanmean(values[n]) for n in ns], lw=0.6, alpha=0.35, color=colour)
            med = [np.nanmedian([r["rmse_mm"] for r in rows if r["method"] == method and r["contacts"] == n])
                   for n in contacts]
            ax.plot(contacts, med, lw=2.5, marker="o", color=colour,
                    label=f"{method} (median; thin: families)")
        ax.axhline(1.5, ls="--", color="grey", lw=0.8)
        ax.set_xscale("log")
        ax.set_xticks(contacts)
        ax.set_xticklabels([str(n) for n in contacts])
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("contacts")
        ax.set_title(f"{which} set")
        ax.legend(fontsize=8)
    axes[0][0].set_ylabel("position RMSE (mm)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", default="tuning,held-out",
                        help="comma-separated: tuning, held-out, registry (default: tuning,held-out)")
    parser.add_argument("--methods", default="default",
                        help=f"comma-separated GPIS methods: {', '.join(METHODS)}")
    parser.add_argument("--contacts", default="100,200,400")
    parser.add_argument("--draws", type=int, default=3, help="contact draws per object and N")
    parser.add_argument("--independent-draws", action="store_true",
                        help="draw each N's contacts on their own instead of nested (the design before 2026-12)")
    parser.add_argument("--quick", action="store_true",
                        help="the first object of each family and one draw (48 cases per method and set)")
    parser.add_argument("--objects", default=None, help="comma-separated names instead of --set")
    parser.add_argument("--resolution", type=int, default=96, help="meshing samples per side")
    parser.add_argument("--samples", type=int, default=10000, help="surface samples per direction")
    parser.add_argument("--threads", type=int, default=1,
                        help="torch threads, >= 1 (default 1: the symmetry search turns the BLAS's last bits, "
                             "which change with the thread count, into another axis; compare runs at one setting)")
    parser.add_argument("--out", type=Path, default=None,
                        help="directory for results.jsonl (re-used), tables.md and error_vs_contacts.png")
    args = parser.parse_args(argv)

    if args.threads < 1:
        parser.error(f"--threads must be at least 1, got {args.threads}")
    import torch

    torch.set_num_threads(args.threads)
    methods = args.methods.split(",")
    for m in methods:
        if m not in METHODS:
            parser.error(f"unknown method {m!r}; choose from {', '.join(METHODS)}")
    try:
        contacts = sorted(int(v) for v in args.contacts.split(","))
    except ValueError:
        parser.error(f"--contacts must be comma-separated integers, got {args.contacts!r}")
    draws = 1 if args.quick else args.draws
    sets = ["custom"] if args.objects else args.set.split(",")
    results_path = None
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        results_path = args.out / "results.jsonl"
    done = load_results(results_path)
    all_rows: dict[str, list[dict]] = {}
    nested = not args.independent_draws
    text = [f"Machine: {platform.machine()}, python {platform.python_version()}; "
            f"draws {draws} ({'nested' if nested else 'independent'}), resolution {args.resolution}, "
            f"torch threads {args.threads}, "
            f"{args.samples} samples per direction"]
    for which in sets:
        names = args.objects.split(",") if args.objects else object_names(which, args.quick)
        rows = []
        for name in names:
            truth = objects.load(name).mesh
            for method in methods:
                for n in contacts:
                    for draw in range(draws):
                        key = (method, name, n, draw, args.resolution, "nested" if nested else "independent")
                        if key not in done:
                            done[key] = run_case(method, name, truth, n, draw, args.resolution, args.samples,
                                                 nested)
                            if results_path is not None:
                                with open(results_path, "a") as fh:
                                    fh.write(json.dumps(done[key]) + "\n")
                            r = done[key]
                            print(f"{which} {method} {name} {n} draw {draw}: RMSE {r['rmse_mm']:.2f} mm, "
                                  f"p99 {r['p99_mm']:.1f} mm", file=sys.stderr, flush=True)
                        rows.append(done[key])
        all_rows[which] = rows
        for method in methods:
            mrows = [r for r in rows if r["method"] == method]
            text += [f"\n### {which} set, method {method} ({len(names)} objects)\n",
                     family_table(mrows, contacts), "", summary(mrows, contacts)]
    report = "\n".join(text)
    print(report)
    if args.out is not None:
        (args.out / "tables.md").write_text(report + "\n")
        figure(all_rows, contacts, args.out / "error_vs_contacts.png")
        print(f"wrote {args.out / 'tables.md'}, {args.out / 'error_vs_contacts.png'}, {results_path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
