"""Reference accuracy table: GPIS from sampled contacts, with and without normals.

For each object, N contacts are sampled area-uniformly from the ground-truth mesh with the sensor
noise model of :mod:`reconstruction.synthetic_contacts`, reconstructed four ways (thin-plate
Williams-Fitzgibbon kernel with normals and a quadratic trend - the default -, the same without the
trend, the reference work's indefinite thin-plate form with normals, and the classic GPIS without
normals), meshed, and compared with the truth by :func:`reconstruction.metrics.surface_error`
(position / normal RMSE, edge error, and the literature's Chamfer L1 / L2, F-score at 1 / 2 / 5 mm
and normal consistency). Prints a Markdown table and writes it (Markdown and CSV) with one
reconstruction per object and method to ``--out``.

    tactile-gpis-bench --out results/reconstruction
"""
from __future__ import annotations

import argparse
import csv
import io
import platform
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import objects
from explorer import outputs
from reconstruction.gpis import GPIS
from reconstruction.metrics import surface_error
from reconstruction.synthetic_contacts import ContactNoise, sample_contacts

#: Reference results (simulation): position RMSE mm / normal RMSE deg, without -> with normals.
REFERENCE = {
    "box": ((5.2, 25), (2.7, 17)),
    "sphere": ((1.9, 6), (0.5, 1)),
    "cylinder": ((6.0, 27), (3.2, 17)),
    "banana": ((5.9, 27), (1.8, 10)),
}
METHODS = {
    "normals": dict(kernel="thin_plate", use_normals=True),
    "normals, no trend": dict(kernel="thin_plate", use_normals=True, trend=None),
    "normals, reference kernel": dict(kernel="thin_plate_reference", use_normals=True, trend=None),
    "no normals": dict(kernel="thin_plate", use_normals=False),
    # the default GPIS, meshed with only the faces it is confident about (issue 10)
    "normals, confident surface": dict(kernel="thin_plate", use_normals=True, max_std_m=2.0e-3),
    # a partition of unity of local GPIS fits (reconstruction.partitioned_gpis; issue 10)
    "normals, partitioned": dict(kernel="thin_plate", use_normals=True, partitioned=True),
    # the default GPIS meshed with the contacts' symmetric images (reconstruction.symmetry; issue 10)
    "normals, symmetry": dict(kernel="thin_plate", use_normals=True, symmetry=True),
    # the same, not cut at the contacts' whole flat faces (GPIS.mesh(cut_at_faces=False): before the cut)
    "normals, symmetry, uncut": dict(kernel="thin_plate", use_normals=True, symmetry=True, cut_at_faces=False),
}
#: The literature's metrics (reconstruction.metrics.ShapeMetrics), means over the seeds.
STANDARD = ("chamfer_l1_mm", "chamfer_l2_mm", "fscore_1mm", "fscore_2mm", "fscore_5mm", "normal_consistency")
#: The known rough location: the object's box grown by this fraction of its largest side.
BOUNDS_PADDING = 0.2


@dataclass(frozen=True)
class Row:
    object: str
    method: str
    seeds: int
    position_rmse_mm: float
    position_rmse_std_mm: float
    normal_rmse_deg: float
    edge_error_mm: float | None
    seconds: float
    chamfer_l1_mm: float = float("nan")
    chamfer_l2_mm: float = float("nan")
    fscore_1mm: float = float("nan")
    fscore_2mm: float = float("nan")
    fscore_5mm: float = float("nan")
    normal_consistency: float = float("nan")


def object_bounds(mesh) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = mesh.bounds
    pad = BOUNDS_PADDING * float(np.max(hi - lo))
    return lo - pad, hi + pad


def reconstruct(method: str, points, normals, bounds, resolution: int, **gp_kwargs):
    settings = dict(METHODS[method])
    max_std_m = settings.pop("max_std_m", None)
    mesh_options = {"symmetry": True} if settings.pop("symmetry", False) else {}
    if not settings.pop("cut_at_faces", True):
        mesh_options["cut_at_faces"] = False
    if settings.pop("partitioned", False):
        from reconstruction.partitioned_gpis import PartitionedGPIS

        settings.pop("kernel")
        gp = PartitionedGPIS(bounds, **settings, **gp_kwargs)
    else:
        gp = GPIS(bounds=bounds, **settings, **gp_kwargs)
    gp.fit(points, normals if settings["use_normals"] else None)
    return gp.mesh(resolution=resolution, max_std_m=max_std_m, **mesh_options)


def evaluate(name: str, n_contacts: int, seeds: int, noise: ContactNoise, resolution: int,
             out: Path | None, first_seed: int = 100, methods: list[str] | None = None) -> list[Row]:
    model = objects.load(name)
    bounds = object_bounds(model.mesh)
    rows = []
    for method in methods or list(METHODS):
        errors, t0 = [], time.perf_counter()
        for seed in range(first_seed, first_seed + seeds):
            points, normals, _, _ = sample_contacts(model.mesh, n_contacts, noise, seed=seed)
            mesh = reconstruct(method, points, normals, bounds, resolution)
            errors.append(surface_error(mesh, model.mesh, sharp_edges=model.sharp_edges, seed=seed))
            if out is not None and seed == first_seed:
                outputs.export_mesh(mesh, out / "meshes" / f"{objects.file_label(name)}_{method.replace(', ', '_').replace(' ', '_')}.ply")
        position = np.array([e.position_rmse_mm for e in errors])
        edge = [e.edge_rmse_mm for e in errors if e.edge_rmse_mm is not None]
        rows.append(Row(name, method, seeds, float(position.mean()), float(position.std()),
                        float(np.mean([e.normal_rmse_deg for e in errors])),
                        float(np.mean(edge)) if edge else None,
                        (time.perf_counter() - t0) / seeds,
                        **{key: float(np.mean([getattr(e, key) for e in errors])) for key in STANDARD}))
    return rows


def markdown(rows: list[Row], n_contacts: int, noise: ContactNoise) -> str:
    lines = [
        f"{n_contacts} contacts per object, noise: {noise.normal_std_m * 1e3:.2f} mm along the normal, "
        f"{noise.tangent_std_m * 1e3:.2f} mm across, normal error mean {noise.normal_error_mean_deg:.1f} deg; "
        f"mean +- std over {rows[0].seeds} seeds. Position / normal RMSE: mean of both directions "
        "(reconstruction -> truth, truth -> reconstruction). Chamfer L1 = mean of the two directional "
        "mean distances, Chamfer L2 = root of the mean of the two directional mean squared distances, "
        "F@t = F-score at t, NC = normal consistency (mean |cos|, both directions); 20 000 area-uniform "
        "samples per direction, distances to the exact surface (`reconstruction.metrics.ShapeMetrics`); "
        "means over the seeds.",
        "",
        "| object | method | position RMSE (mm) | normal RMSE (deg) | edge error (mm) "
        "| Chamfer L1 (mm) | Chamfer L2 (mm) | F@1mm | F@2mm | F@5mm | NC "
        "| reference (mm / deg) | s per run |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        ref = REFERENCE.get(r.object)
        ref_text = "-"
        if ref is not None:
            ref_mm, ref_deg = ref[0] if r.method == "no normals" else ref[1]
            ref_text = f"{ref_mm} / {ref_deg}"
        edge = "-" if r.edge_error_mm is None else f"{r.edge_error_mm:.2f}"
        lines.append(f"| {r.object} | {r.method} | {r.position_rmse_mm:.2f} +- {r.position_rmse_std_mm:.2f} "
                     f"| {r.normal_rmse_deg:.1f} | {edge} | {r.chamfer_l1_mm:.2f} | {r.chamfer_l2_mm:.2f} "
                     f"| {r.fscore_1mm:.3f} | {r.fscore_2mm:.3f} | {r.fscore_5mm:.3f} | {r.normal_consistency:.3f} "
                     f"| {ref_text} | {r.seconds:.1f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    from scripts._cli import check_object, check_out_dir, float_above, int_at_least

    parser = argparse.ArgumentParser(prog="tactile-gpis-bench", description=__doc__.splitlines()[0])
    parser.add_argument("--objects", default=",".join(objects.names()),
                        help="comma-separated registry names, generated:FAMILY/SEED names or mesh files")
    parser.add_argument("--units", choices=("m", "cm", "mm", "in"), default="m",
                        help="length unit of the mesh files in --objects (default m)")
    parser.add_argument("--contacts", type=int_at_least(1), default=100)
    parser.add_argument("--seeds", type=int_at_least(1), default=5, help="number of sampling seeds, >= 1")
    parser.add_argument("--first-seed", type=int_at_least(0), default=100,
                        help="contact sampling seeds start here (0-9 were used to choose defaults)")
    parser.add_argument("--resolution", type=int_at_least(8), default=96, help="meshing samples per side")
    parser.add_argument("--normal-std-mm", type=float_above(0.0, inclusive=True),
                        default=ContactNoise().normal_std_m * 1e3)
    parser.add_argument("--tangent-std-mm", type=float_above(0.0, inclusive=True),
                        default=ContactNoise().tangent_std_m * 1e3)
    parser.add_argument("--normal-error-deg", type=float_above(0.0, inclusive=True),
                        default=ContactNoise().normal_error_mean_deg)
    parser.add_argument("--methods", default=";".join(METHODS),
                        help=f"semicolon-separated (names contain commas), from: {'; '.join(METHODS)}")
    parser.add_argument("--out", type=Path, default=None,
                        help="directory for table, CSV and meshes (new or empty)")
    args = parser.parse_args(argv)
    methods = [m.strip() for m in args.methods.split(";")]
    for m in methods:
        if m not in METHODS:
            parser.error(f"--methods: unknown method {m!r}; choose from {'; '.join(METHODS)}")
    names = [n.strip() for n in args.objects.split(",")]
    if not all(names):
        parser.error(f"--objects {args.objects!r}: empty name")
    for i, name in enumerate(names):
        check_object(parser, name, "--objects")
        if objects.is_mesh_file_name(name):
            try:
                names[i] = objects.in_metres(name, args.units)
            except (ValueError, FileNotFoundError) as error:
                parser.error(str(error))
    if args.out is not None:
        check_out_dir(parser, args.out)
    try:
        noise = ContactNoise(args.normal_std_mm * 1e-3, args.tangent_std_mm * 1e-3, args.normal_error_deg)
    except ValueError as error:
        parser.error(str(error))
    if args.out is not None:
        (args.out / "meshes").mkdir(parents=True, exist_ok=True)
    rows = []
    for name in names:
        rows.extend(evaluate(name, args.contacts, args.seeds, noise, args.resolution, args.out,
                             args.first_seed, methods))
        print(f"done {name}", flush=True)
    text = markdown(rows, args.contacts, noise)
    machine = f"{platform.machine()}, python {platform.python_version()}"
    print(f"\n{text}\n\nMachine: {machine}")
    if args.out is not None:
        outputs.write_text(args.out / "accuracy.md", text + f"\n\nMachine: {machine}\n")
        table = io.StringIO()
        writer = csv.writer(table)
        writer.writerow(Row.__dataclass_fields__.keys())
        for r in rows:
            writer.writerow(r.__dict__.values())
        outputs.write_text(args.out / "accuracy.csv", table.getvalue())
        print(f"wrote {args.out / 'accuracy.md'}, {args.out / 'accuracy.csv'} and meshes/")


if __name__ == "__main__":
    main()
