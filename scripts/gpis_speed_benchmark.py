"""GPIS speed benchmark: fit, incremental add, meshing and variance versus the number of contacts.

Prints a Markdown table (and writes it with ``--out``) with the machine noted. Every ratio is
against a baseline measured in the same run (full refit for ``add``, dense grid for meshing, full
recomputation for the variance). Contacts lie on a sphere of radius 5 cm with exact normals.

    python -m scripts.gpis_speed_benchmark --sizes 100,250,500,1000,2000
"""
from __future__ import annotations

import argparse
import os
import platform
import resource
import statistics
import time
from pathlib import Path

import numpy as np
import torch

from reconstruction.gpis import GPIS
from reconstruction.meshing import evaluate_coarse_to_fine, evaluate_dense, grid_axes
from reconstruction.synthetic_contacts import sphere_contacts

BOUNDS = ((-0.08, -0.08, -0.08), (0.08, 0.08, 0.08))


def timed(fn, repeat: int = 1) -> float:
    """Median wall time of ``fn()`` in seconds."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def measure(n: int, grid: int, candidates: int, dense: bool, seed: int = 0, partitioned: bool = False,
            **gpis_kwargs) -> dict:
    points, normals = sphere_contacts(n + 20, seed=seed)
    if partitioned:
        from reconstruction.partitioned_gpis import PartitionedGPIS

        gp = PartitionedGPIS(BOUNDS, **gpis_kwargs)
    else:
        gp = GPIS(bounds=BOUNDS, **gpis_kwargs)
    fit_s = timed(lambda: gp.fit(points[:n], normals[:n]), repeat=2 if n <= 1000 else 1)

    add_times = []
    for p, nrm in zip(points[n:n + 10], normals[n:n + 10]):
        add_times.append(timed(lambda: gp.add(p, nrm)))
    add_s = statistics.median(add_times)

    cand = 0.065 * sphere_contacts(candidates, seed=seed + 1)[1]
    tracker = gp.variance_tracker(cand)
    full_var_s = timed(tracker.variance)  # first call: full recomputation
    var_times = []
    for p, nrm in zip(points[n + 10:n + 20], normals[n + 10:n + 20]):
        gp.add(p, nrm)
        var_times.append(timed(tracker.variance))
    var_inc_s = statistics.median(var_times)

    axes = grid_axes(gp.region, grid)
    gp.mean(np.zeros((1, 3)))  # weights computed outside the timing
    t0 = time.perf_counter()
    evaluate_coarse_to_fine(gp.mean, axes)
    c2f_s = time.perf_counter() - t0
    mesh_s = timed(lambda: gp.mesh(resolution=grid))
    mesh = gp.mesh(resolution=grid)
    # the confident surface adds the posterior variance at vertices farther than 4 mm from a contact
    confident_s = timed(lambda: gp.mesh(resolution=grid, max_std_m=2e-3)) - mesh_s
    max_f = float(np.abs(gp.mean(mesh.vertices)).max())
    dense_s = timed(lambda: evaluate_dense(gp.mean, axes)) if dense else float("nan")

    factor_mb = 8 * gp.n_rows**2 / 1e6
    tracker_mb = tracker.nbytes / 1e6
    return dict(n=n, rows=gp.n_rows, fit_s=fit_s, add_ms=1e3 * add_s, refit_over_add=fit_s / add_s,
                c2f_s=c2f_s, mesh_s=mesh_s, confident_s=confident_s, dense_s=dense_s, dense_over_c2f=dense_s / c2f_s,
                max_f=max_f, var_inc_ms=1e3 * var_inc_s, var_full_ms=1e3 * full_var_s,
                factor_mb=factor_mb, tracker_mb=tracker_mb)


def machine() -> str:
    return (f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
            f"torch {torch.__version__} with {torch.get_num_threads()} threads, "
            f"python {platform.python_version()}")


def table(rows: list[dict], grid: int, candidates: int) -> str:
    head = (f"| contacts | rows | fit (s) | add (ms) | refit/add | mean field {grid}^3 coarse-to-fine (s) "
            f"| mesh total (s) | confident surface, extra (s) | dense {grid}^3 (s) | dense/c2f | max abs f at vertices "
            f"| variance {candidates} cand., incremental (ms) | full recompute (ms) "
            "| factor (MB) | variance tracker (MB) |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for r in rows:
        dense = "-" if np.isnan(r["dense_s"]) else f"{r['dense_s']:.2f}"
        ratio = "-" if np.isnan(r["dense_s"]) else f"{r['dense_over_c2f']:.1f}x"
        lines.append(
            f"| {r['n']} | {r['rows']} | {r['fit_s']:.3f} | {r['add_ms']:.1f} | {r['refit_over_add']:.0f}x "
            f"| {r['c2f_s']:.2f} | {r['mesh_s']:.2f} | {r['confident_s']:.2f} | {dense} | {ratio} | {r['max_f']:.1e} "
            f"| {r['var_inc_ms']:.1f} | {r['var_full_ms']:.0f} | {r['factor_mb']:.0f} | {r['tracker_mb']:.0f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="100,250,500,1000,2000",
                        help="comma-separated contact counts")
    parser.add_argument("--grid", type=int, default=128, help="meshing samples per side")
    parser.add_argument("--candidates", type=int, default=10000, help="variance candidates")
    parser.add_argument("--dense-up-to", type=int, default=1000,
                        help="also time the dense grid for sizes up to this")
    parser.add_argument("--out", type=Path, help="write the Markdown table here")
    parser.add_argument("--baseline-normal-noise", type=float, default=None,
                        help="also time GPIS(normal_noise=this, opposing_normal_noise=None) (0.2: the "
                             "default before issue 10) and print add and variance ratios against it")
    parser.add_argument("--partitioned", action="store_true",
                        help="also time reconstruction.PartitionedGPIS (its defaults) and print add and "
                             "variance ratios against the default GPIS")
    args = parser.parse_args(argv)
    sizes = [int(s) for s in args.sizes.split(",")]
    rows = []
    for n in sizes:
        rows.append(measure(n, args.grid, args.candidates, dense=n <= args.dense_up_to))
        print(f"measured {n} contacts", flush=True)
    ratios = ""
    if args.baseline_normal_noise is not None:
        lines = [f"\nBaseline GPIS(normal_noise={args.baseline_normal_noise}) in the same run:"]
        for r in rows:
            b = measure(r["n"], args.grid, args.candidates, dense=False,
                        normal_noise=args.baseline_normal_noise, opposing_normal_noise=None)
            lines.append(f"{r['n']} contacts: add {r['add_ms']:.1f} vs {b['add_ms']:.1f} ms "
                         f"({r['add_ms'] / b['add_ms']:.2f}x), incremental variance {r['var_inc_ms']:.1f} vs "
                         f"{b['var_inc_ms']:.1f} ms ({r['var_inc_ms'] / b['var_inc_ms']:.2f}x)")
        ratios = "\n".join(lines) + "\n"
    if args.partitioned:
        lines = ["\nPartitionedGPIS in the same run:"]
        for r in rows:
            b = measure(r["n"], args.grid, args.candidates, dense=False, partitioned=True)
            lines.append(f"{r['n']} contacts: fit {b['fit_s']:.3f} vs {r['fit_s']:.3f} s, add {b['add_ms']:.1f} vs "
                         f"{r['add_ms']:.1f} ms ({b['add_ms'] / r['add_ms']:.2f}x the default), incremental variance "
                         f"{b['var_inc_ms']:.1f} vs {r['var_inc_ms']:.1f} ms ({b['var_inc_ms'] / r['var_inc_ms']:.2f}x), "
                         f"mesh {b['mesh_s']:.2f} vs {r['mesh_s']:.2f} s, tracker {b['tracker_mb']:.0f} MB")
        ratios += "\n".join(lines) + "\n"
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    text = (f"Machine: {machine()}\n\n{table(rows, args.grid, args.candidates)}\n{ratios}\n"
            f"Peak resident memory of the benchmark process: {peak_mb:.0f} MB\n")
    print(text)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(text)


if __name__ == "__main__":
    main()
