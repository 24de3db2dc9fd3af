"""How much Rerun logging (``--rerun``) slows an exploration run: the same run with and without.

    python -m scripts.rerun_overhead_benchmark --object banana --touches 20 --repeats 2

Runs alternate (without, with, without, with, ...) with the same seed, so both see the same
machine load on average; prints each wall time, the ratio of the medians and the machine.
Outputs under ``--out`` (default a temporary directory).
"""
from __future__ import annotations

import argparse
import os
import platform
import statistics
import tempfile
import time
from pathlib import Path


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--object", default="banana")
    parser.add_argument("--touches", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--surface-every", type=int, default=10, help="GPIS surface every k touches")
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args(argv)

    import torch

    from explorer.rerun_view import RerunObserver, open_stream
    from explorer.run import RunSettings, explore

    torch.set_num_threads(1)
    out = args.out or Path(tempfile.mkdtemp(prefix="rerun_overhead_"))
    settings = RunSettings(object=args.object, touches=args.touches, seed=args.seed)
    walls: dict[bool, list[float]] = {False: [], True: []}
    contacts: dict[bool, list[int]] = {False: [], True: []}
    for repeat in range(args.repeats):
        for logged in (False, True):
            name = f"{'rerun' if logged else 'plain'}{repeat}"
            observer = (RerunObserver(open_stream(out / f"{name}.rrd"), surface_every=args.surface_every)
                        if logged else None)
            start = time.perf_counter()
            result = explore(settings, out / name, observer=observer)
            walls[logged].append(time.perf_counter() - start)
            contacts[logged].append(result.metrics["contacts"])
            print(f"{name}: {walls[logged][-1]:.1f} s wall, {result.metrics['contacts']} contacts", flush=True)
    plain, logged = statistics.median(walls[False]), statistics.median(walls[True])
    size_mb = statistics.median((out / f"rerun{i}.rrd").stat().st_size for i in range(args.repeats)) / 1e6
    print(f"\n{args.object}, {args.touches} touches, seed {args.seed}, surface every {args.surface_every} touches")
    print(f"median wall without Rerun {plain:.1f} s, with {logged:.1f} s: ratio {logged / plain:.3f}; "
          f"recording {size_mb:.1f} MB")
    print(f"Machine: {platform.machine()}, {os.cpu_count()} cores, python {platform.python_version()}")


if __name__ == "__main__":
    main()
