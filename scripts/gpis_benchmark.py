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
import platform
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import objects
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
    gp = GPIS(bounds=bounds, **METHODS[method], **gp_kwargs)
    gp.fit(points, normals if METHODS[method]["use_normals"] else None)
    return gp.mesh(resolution=resolution)


def evaluate(name: str, n_contacts: int, seeds: int, noise: ContactNoise, resolution: int,
             out: Path | None, first_seed: int = 100) -> list[Row]:
    model = objects.load(name)
    bounds = object_bounds(model.mesh)
    rows = []
    for method in METHODS:
        errors, t0 = [], time.perf_counter()
        for seed in range(first_seed, first_seed + seeds):
            points, normals, _, _ = sample_contacts(model.mesh, n_contacts, noise, seed=seed)
            mesh = reconstruct(method, points, normals, bounds, resolution)
            errors.append(surface_error(mesh, model.mesh, sharp_edges=model.sharp_edges, seed=seed))
            if out is not None and seed == first_seed:
                mesh.export(out / "meshes" / f"{objects.file_label(name)}_{method.replace(', ', '_').replace(' ', '_')}.ply")
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
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--objects", default=",".join(objects.names()),
                        help="comma-separated registry names, generated:FAMILY/SEED names or mesh files")
    parser.add_argument("--units", choices=("m", "cm", "mm", "in"), default="m",
                        help="length unit of the mesh files in --objects (default m)")
    parser.add_argument("--contacts", type=int, default=100)
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--first-seed", type=int, default=100,
                        help="contact sampling seeds start here (0-9 were used to choose defaults)")
    parser.add_argument("--resolution", type=int, default=96, help="meshing samples per side")
    parser.add_argument("--normal-std-mm", type=float, default=ContactNoise().normal_std_m * 1e3)
    parser.add_argument("--tangent-std-mm", type=float, default=ContactNoise().tangent_std_m * 1e3)
    parser.add_argument("--normal-error-deg", type=float, default=ContactNoise().normal_error_mean_deg)
    parser.add_argument("--out", type=Path, default=None, help="directory for table, CSV and meshes")
    args = parser.parse_args(argv)

    noise = ContactNoise(args.normal_std_mm * 1e-3, args.tangent_std_mm * 1e-3, args.normal_error_deg)
    if args.out is not None:
        (args.out / "meshes").mkdir(parents=True, exist_ok=True)
    rows = []
    for name in args.objects.split(","):
        if objects.is_mesh_file_name(name):
            try:
                name = objects.in_metres(name, args.units)
            except (ValueError, FileNotFoundError) as error:
                parser.error(str(error))
        rows.extend(evaluate(name, args.contacts, args.seeds, noise, args.resolution, args.out,
                             args.first_seed))
        print(f"done {name}", flush=True)
    text = markdown(rows, args.contacts, noise)
    machine = f"{platform.machine()}, python {platform.python_version()}"
    print(f"\n{text}\n\nMachine: {machine}")
    if args.out is not None:
        (args.out / "accuracy.md").write_text(text + f"\n\nMachine: {machine}\n")
        with open(args.out / "accuracy.csv", "w", newline="") as fh:
            writer = csv.writer(fh)
            writer.writerow(Row.__dataclass_fields__.keys())
            for r in rows:
                writer.writerow(r.__dict__.values())
        print(f"wrote {args.out / 'accuracy.md'}, {args.out / 'accuracy.csv'} and meshes/")


if __name__ == "__main__":
    main()
